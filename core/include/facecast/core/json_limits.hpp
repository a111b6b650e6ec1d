#pragma once
// Bounds on JSON from outside, checked on the raw bytes before any parser sees them: a recursive
// parser (tinygltf's, or the destructor of a deeply nested document) runs out of stack on input
// that nests deeply, however small the file. One linear scan, no allocation.
#include <cstddef>
#include <string_view>

namespace facecast {

/// Throws Error(kLimit) when `text` nests arrays and objects deeper than `max_depth`:
/// "<what>: JSON nests deeper than <max_depth> levels at byte <offset>". Strings (with their
/// escapes) are skipped; the text is not otherwise validated (the parser does that).
void check_json_depth(std::string_view text, int max_depth, std::string_view what);

/// The deepest nesting of arrays and objects in `text` (0 for a scalar), scanning no further
/// than one level past `stop_at` (so a hostile input costs at most its length).
int json_depth(std::string_view text, int stop_at, std::size_t* offset = nullptr);

}  // namespace facecast
