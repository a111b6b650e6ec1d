#include "build_paths.hpp"

namespace facecast::test {

std::filesystem::path source_dir() {
  return FACECAST_SOURCE_DIR;
}
std::filesystem::path build_dir() {
  return FACECAST_BUILD_DIR;
}
std::filesystem::path test_data_dir() {
  return build_dir() / "test-data";
}
std::filesystem::path facecast_exe() {
  return FACECAST_EXE;
}
std::filesystem::path cmake_command() {
  return FACECAST_CMAKE;
}

}  // namespace facecast::test
