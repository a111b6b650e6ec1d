# Warnings, sanitizers and the `facecast_library` helper shared by every module.

add_library(facecast_options INTERFACE)
target_compile_options(facecast_options INTERFACE -Wall -Wextra -Wpedantic -Wshadow
                       -Wnon-virtual-dtor -Wcast-align -Wunused -Woverloaded-virtual)
if(FACECAST_WERROR)
  target_compile_options(facecast_options INTERFACE -Werror)
endif()
if(CMAKE_UNITY_BUILD)
  # In a unity build every source is an included file, so GCC takes a class in one .cpp holding a
  # type from that file's anonymous namespace for a header's (it is not: the batch is one file).
  target_compile_options(facecast_options INTERFACE $<$<CXX_COMPILER_ID:GNU>:-Wno-subobject-linkage>)
endif()

if(FACECAST_SANITIZE AND FACECAST_TSAN)
  message(FATAL_ERROR "FACECAST_SANITIZE and FACECAST_TSAN cannot be combined")
endif()
if(FACECAST_SANITIZE)
  # Applied globally so third-party headers instantiated in our code agree on the ABI. GCC 12's
  # -Wmaybe-uninitialized gives false positives inside libstdc++ (std::regex) under ASan.
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined
                      $<$<CXX_COMPILER_ID:GNU>:-Wno-maybe-uninitialized>)
  add_link_options(-fsanitize=address,undefined)
endif()
if(FACECAST_TSAN)
  add_compile_options(-fsanitize=thread -fno-omit-frame-pointer)
  add_link_options(-fsanitize=thread)
endif()

# facecast_library(<module> SOURCES ... [DEPS ...] [PRIVATE_DEPS ...] [HOT] [FORK_JOIN])
# One library per top-level folder: public headers in <module>/include, private code in <module>/src.
# HOT: compute that most tests run through (the built-in avatar's generator, in every test that
# starts a server), compiled at -O2 in the sanitizer trees (built at -O1) and without UBSan's
# checks (ASan's stay; whole-program ASan is what keeps Eigen's allocations compatible): its input
# is a handful of bounded parameters, never outside bytes, and UBSan's checks of its float math
# took two thirds of its time there (docs/benchmarks.md#build-time).
# FORK_JOIN: numeric work whose only threads are fork-join loops (each task writes its own outputs,
# every future is joined before the call returns; locks are pthread's, which ThreadSanitizer
# intercepts anyway), compiled without ThreadSanitizer's instrumentation in its tree: that stage
# checks the server's concurrency, and the instrumented rig builds and photo fits its cases run took
# half of it (docs/benchmarks.md#build-time).
function(facecast_library name)
  cmake_parse_arguments(ARG "HOT;FORK_JOIN" "" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(facecast_${name} ${ARG_SOURCES})
  add_library(facecast::${name} ALIAS facecast_${name})
  target_include_directories(facecast_${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include
                             PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_link_libraries(facecast_${name} PUBLIC ${ARG_DEPS} PRIVATE facecast_options ${ARG_PRIVATE_DEPS})
  if(ARG_HOT AND (FACECAST_SANITIZE OR FACECAST_TSAN))
    target_compile_options(facecast_${name} PRIVATE -O2)
  endif()
  if(ARG_HOT AND FACECAST_SANITIZE)
    target_compile_options(facecast_${name} PRIVATE -fno-sanitize=undefined)
  endif()
  if(ARG_FORK_JOIN AND FACECAST_TSAN)
    target_compile_options(facecast_${name} PRIVATE -fno-sanitize=thread)
  endif()
endfunction()

# facecast_source_paths(<source> NAME="value" ...)
# Definitions holding absolute paths (this checkout's, its build folder's), given to one source file
# only: a path differs in every clone, and in a target's flags ccache's direct mode would miss every
# file of that target in a fresh clone (which is what CI builds) and preprocess each instead.
function(facecast_source_paths source)
  set_property(SOURCE ${source} APPEND PROPERTY COMPILE_DEFINITIONS ${ARGN})
endfunction()
