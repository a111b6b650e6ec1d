#include "test_data.hpp"

#include "build_paths.hpp"

#include <unistd.h>
#include <catch2/catch.hpp>
#include <cstdlib>
#include <string>

#include "facecast/core/config.hpp"

namespace facecast::test {

std::filesystem::path shared_data() {
  return facecast::shared_data_dir();
}

std::filesystem::path ict_dir() {
  return test_data_dir() / "ict-facekit" / "FaceXModel";
}

std::filesystem::path artifacts_dir(const std::string& name) {
  const auto dir = build_dir() / "test-artifacts" / name;
  std::filesystem::create_directories(dir);
  return dir;
}

namespace {
struct Scratch {
  std::filesystem::path path;
  Scratch() {
    path = std::filesystem::temp_directory_path() / ("facecast-test-" + std::to_string(getpid()));
    std::filesystem::create_directories(path);
  }
  ~Scratch() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};
}  // namespace

std::filesystem::path scratch_dir() {
  static Scratch s;
  return s.path;
}

bool require_data(const std::filesystem::path& path) {
  if (std::filesystem::exists(path)) return true;
  const char* ci = std::getenv("CI");
  if (ci && std::string(ci) == "true") {
    FAIL("required test data missing: " << path.string());
  }
  WARN("test data missing, test not run: " << path.string());
  return false;
}

}  // namespace facecast::test
