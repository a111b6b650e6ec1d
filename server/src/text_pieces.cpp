#include "text_pieces.hpp"

#include <string_view>

namespace facecast::server {
namespace {

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r';
}

// Chinese clause marks (UTF-8): 。！？；，、：
bool is_cjk_mark(std::string_view s) {
  static constexpr std::string_view kMarks[] = {"\u3002", "\uff01", "\uff1f", "\uff1b",
                                                "\uff0c", "\u3001", "\uff1a"};
  for (const auto m : kMarks) {
    if (s.starts_with(m)) return true;
  }
  return false;
}

void push_trimmed(std::vector<std::string>& out, std::string_view piece) {
  while (!piece.empty() && is_space(piece.front())) piece.remove_prefix(1);
  while (!piece.empty() && is_space(piece.back())) piece.remove_suffix(1);
  if (!piece.empty()) out.emplace_back(piece);
}

}  // namespace

std::vector<std::string> take_pieces(std::string& buffer, bool final) {
  std::vector<std::string> out;
  std::size_t begin = 0;
  int depth = 0;  // inside an expression tag "(joy, 40, 0.5)"
  for (std::size_t i = 0; i < buffer.size(); ++i) {
    const char c = buffer[i];
    if (c == '(') ++depth;
    if (c == ')' && depth > 0) --depth;
    if (depth > 0) continue;
    std::size_t cut = 0;  // end of the piece (exclusive), 0: no cut here
    if (c == '\n') {
      cut = i + 1;
    } else if ((c == '.' || c == '!' || c == '?' || c == ';') && i + 1 < buffer.size() &&
               is_space(buffer[i + 1])) {
      cut = i + 1;  // "3.5" and "e.g" stay whole: a sentence end is followed by white space
    } else if (is_cjk_mark(std::string_view(buffer).substr(i))) {
      cut = i + 3;
    }
    if (cut == 0) continue;
    push_trimmed(out, std::string_view(buffer).substr(begin, cut - begin));
    begin = cut;
    i = cut - 1;
  }
  if (final) {
    push_trimmed(out, std::string_view(buffer).substr(begin));
    begin = buffer.size();
  }
  buffer.erase(0, begin);
  return out;
}

}  // namespace facecast::server
