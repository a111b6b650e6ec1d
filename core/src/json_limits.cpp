#include "facecast/core/json_limits.hpp"

#include <string>

#include "facecast/core/error.hpp"

namespace facecast {

int json_depth(std::string_view text, int stop_at, std::size_t* offset) {
  int depth = 0, deepest = 0;
  bool in_string = false, escaped = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (escaped) {
        escaped = false;
      } else if (c == '\\') {
        escaped = true;
      } else if (c == '"') {
        in_string = false;
      }
      continue;
    }
    if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > deepest) {
        deepest = depth;
        if (deepest > stop_at) {
          if (offset) *offset = i;
          return deepest;
        }
      }
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  return deepest;
}

void check_json_depth(std::string_view text, int max_depth, std::string_view what) {
  std::size_t at = 0;
  if (json_depth(text, max_depth, &at) > max_depth) {
    throw Error(std::string(what) + ": JSON nests deeper than " + std::to_string(max_depth) +
                    " levels at byte " + std::to_string(at),
                ErrorCode::kLimit);
  }
}

}  // namespace facecast
