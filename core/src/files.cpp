#include "facecast/core/files.hpp"

#include <fstream>
#include <random>
#include <sstream>
#include <system_error>

#include "facecast/core/error.hpp"

namespace facecast {

std::string_view to_string(ErrorCode code) noexcept {
  switch (code) {
    case ErrorCode::kInvalidInput:
      return "invalid_input";
    case ErrorCode::kNotFound:
      return "not_found";
    case ErrorCode::kUnsupported:
      return "unsupported";
    case ErrorCode::kLimit:
      return "limit";
    case ErrorCode::kInternal:
      return "internal";
  }
  return "internal";
}

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path.string() + ": cannot open file", ErrorCode::kNotFound);
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw Error(path.string() + ": read error", ErrorCode::kInternal);
  return std::move(ss).str();
}

namespace {
std::filesystem::path temp_sibling(const std::filesystem::path& path) {
  thread_local std::mt19937_64 rng{std::random_device{}()};
  auto tmp = path;
  tmp += ".tmp" + std::to_string(rng() % 1000000000ULL);
  return tmp;
}
}  // namespace

void write_file_atomic(const std::filesystem::path& path,
                       const std::function<void(std::ostream&)>& write) {
  if (path.has_parent_path()) {
    std::error_code ec;
    std::filesystem::create_directories(path.parent_path(), ec);
    if (ec)
      throw Error(path.string() + ": cannot create folder: " + ec.message(), ErrorCode::kInternal);
  }
  const auto tmp = temp_sibling(path);
  try {
    {
      std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
      if (!out) throw Error(path.string() + ": cannot write file", ErrorCode::kInternal);
      write(out);
      out.flush();
      if (!out) throw Error(path.string() + ": write error", ErrorCode::kInternal);
    }
    std::error_code ec;
    std::filesystem::rename(tmp, path, ec);
    if (ec) throw Error(path.string() + ": cannot rename: " + ec.message(), ErrorCode::kInternal);
  } catch (...) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    throw;
  }
}

void write_file_atomic(const std::filesystem::path& path, std::string_view bytes) {
  write_file_atomic(path, [&](std::ostream& out) {
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  });
}

}  // namespace facecast
