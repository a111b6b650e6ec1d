#pragma once
// File helpers: whole-file reads and atomic writes (temporary file in the same folder, then
// rename), so a failed or interrupted write never leaves a half-written output behind.
#include <filesystem>
#include <functional>
#include <ostream>
#include <string>
#include <string_view>

namespace facecast {

/// Reads a whole file; throws Error(kNotFound) naming the path when it cannot be opened.
std::string read_file(const std::filesystem::path& path);

/// Writes `bytes` to `path` atomically.
void write_file_atomic(const std::filesystem::path& path, std::string_view bytes);

/// Calls `write` with a stream on a temporary file next to `path`, then renames it over `path`.
/// If `write` throws, the temporary file is removed and `path` is untouched.
void write_file_atomic(const std::filesystem::path& path,
                       const std::function<void(std::ostream&)>& write);

}  // namespace facecast
