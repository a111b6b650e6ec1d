# Extracts ../shared/data/ict-facekit.tar.xz into DST (once). Run by the extract_shared_data test.
# A missing tarball does not fail this fixture: the unit tests that need no real data still run, and
# each test that needs the data fails on its own when CI=true (test::require_data), else warns.
set(tarball ${SRC}/ict-facekit.tar.xz)
if(NOT EXISTS ${tarball})
  message(WARNING "shared data missing: ${tarball}; the tests that need it fail with CI=true, "
                  "else warn and pass")
  return()
endif()
if(EXISTS ${DST}/ict-facekit/FaceXModel/generic_neutral_mesh.obj)
  return()
endif()
file(MAKE_DIRECTORY ${DST})
execute_process(COMMAND ${CMAKE_COMMAND} -E tar xJf ${tarball} WORKING_DIRECTORY ${DST}
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cannot extract ${tarball}")
endif()
