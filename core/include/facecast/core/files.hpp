#pragma once
// File helpers: whole-file reads and atomic, durable writes. A write goes to a temporary sibling
// ("<name>.tmp<random>"), is flushed to the disk (fsync), renamed over the target, and the folder
// is flushed too: a failed, interrupted or power-cut write leaves either the old file or the new
// one, never a half-written one. Leftover temporaries of a killed process are removed at the next
// start (sweep_temp_files). Every descriptor these open is close-on-exec.
#include <cstddef>
#include <filesystem>
#include <functional>
#include <ostream>
#include <string>
#include <string_view>

namespace facecast {

/// Reads a whole file; throws Error(kNotFound) naming the path when it cannot be opened.
std::string read_file(const std::filesystem::path& path);

/// Writes `bytes` to `path` atomically and durably.
void write_file_atomic(const std::filesystem::path& path, std::string_view bytes);

/// Calls `write` with a stream on a temporary file next to `path`, then commits it over `path`
/// (commit_file). If `write` throws, the temporary file is removed and `path` is untouched.
void write_file_atomic(const std::filesystem::path& path,
                       const std::function<void(std::ostream&)>& write);

/// A fresh temporary sibling of `path`: "<path>.tmp" + 12 random hex digits (is_temp_name).
std::filesystem::path temp_sibling(const std::filesystem::path& path);

/// fsync(2) of a file, or of a folder (its entries: after creating, renaming or removing in it).
/// Throws Error(kInternal) naming the path.
void fsync_path(const std::filesystem::path& path);

/// Commits finished data: flushes `from` (a file, or a folder whose files were committed), renames
/// it to `to` (replacing a file; a folder `to` must not exist) and flushes `to`'s folder. Throws
/// Error(kInternal) naming `to`; `from` is left for the caller to remove.
void commit_file(const std::filesystem::path& from, const std::filesystem::path& to);

/// Whether a file name is a temporary one a write in progress uses (it contains ".tmp").
bool is_temp_name(std::string_view name);

/// Removes the temporary leftovers (is_temp_name: files and whole folders) directly inside `dir`
/// whose last change is at least `min_age` seconds old; returns how many it removed. A missing
/// `dir` has none; errors on single entries are skipped.
std::size_t sweep_temp_files(const std::filesystem::path& dir, double min_age = 0);

}  // namespace facecast
