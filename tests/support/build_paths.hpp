#pragma once
// Where this checkout and its build folder are, for the tests and the benchmarks. The paths are
// compiled into build_paths.cpp alone: an absolute path in every file's -D differs in every clone,
// and ccache's direct mode then misses every such file in a fresh clone (what CI builds).
#include <filesystem>

namespace facecast::test {

/// The checkout (the folder with CMakeLists.txt).
std::filesystem::path source_dir();
/// The CMake build folder these tests were built in.
std::filesystem::path build_dir();
/// <build>/test-data: ../shared/data extracted by the extract_shared_data fixture.
std::filesystem::path test_data_dir();
/// The `facecast` command built in this folder.
std::filesystem::path facecast_exe();
/// The cmake that configured this folder.
std::filesystem::path cmake_command();

}  // namespace facecast::test
