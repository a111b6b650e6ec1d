#include "text_pieces.hpp"

#include "facecast/core/utf8.hpp"
#include "facecast/server/protocol.hpp"

namespace facecast::server {
namespace {

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r';
}

// Chinese clause marks (UTF-8, 3 bytes each): 。！？；，、：
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

std::vector<std::string> TextPieces::add(std::string_view text, std::string_view field) {
  const std::size_t n = utf8_length(text);
  if (characters_ + n > max_text_) {
    throw RequestError(Code::kLimit, std::string(field) + ": the utterance would have " +
                                         std::to_string(characters_ + n) +
                                         " characters, the limit is " + std::to_string(max_text_));
  }
  characters_ += n;
  buffer_ += text;
  std::vector<std::string> out;
  scan(out, false);
  return out;
}

std::vector<std::string> TextPieces::finish() {
  std::vector<std::string> out;
  scan(out, true);
  cut(out, buffer_.size());
  return out;
}

// Moves buffer_[0, at) into `out` as a piece; the scan state restarts at `at`.
void TextPieces::cut(std::vector<std::string>& out, std::size_t at) {
  push_trimmed(out, std::string_view(buffer_).substr(0, at));
  buffer_.erase(0, at);
  scanned_ -= at;
  piece_chars_ = 0;
  for (std::size_t i = 0; i < scanned_; ++i) piece_chars_ += !is_utf8_continuation(buffer_[i]);
  last_space_ = 0;
}

void TextPieces::scan(std::vector<std::string>& out, bool final) {
  while (scanned_ < buffer_.size()) {
    const std::size_t i = scanned_;
    const char c = buffer_[i];
    const std::string_view rest = std::string_view(buffer_).substr(i);
    // A sentence end needs the next byte, a clause mark its three: wait for them unless closed.
    const bool punct = c == '.' || c == '!' || c == '?' || c == ';';
    const bool mark_lead =
        static_cast<unsigned char>(c) == 0xE3 || static_cast<unsigned char>(c) == 0xEF;
    if (!final && ((punct && rest.size() < 2) || (mark_lead && rest.size() < 3))) return;
    if (c == '(') ++depth_;
    if (c == ')' && depth_ > 0) --depth_;
    std::size_t end = 0;  // end of the piece (exclusive) when it ends here
    if (depth_ == 0) {
      if (c == '\n') {
        end = i + 1;
      } else if (punct && rest.size() >= 2 && is_space(rest[1])) {
        end = i + 1;  // "3.5" and "e.g" stay whole: a sentence end is followed by white space
      } else if (is_cjk_mark(rest)) {
        end = i + 3;
      } else if (is_space(c)) {
        last_space_ = i + 1;
      }
    }
    const std::size_t width = end > i ? end - i : 1;
    scanned_ = i + width;
    piece_chars_ += is_utf8_continuation(c) ? 0 : 1;
    if (end) {
      cut(out, end);
    } else if (piece_chars_ >= max_piece_ &&
               !(scanned_ < buffer_.size() && is_utf8_continuation(buffer_[scanned_]))) {
      // Too long without a sentence end: cut at the last space, or here (a tag left open by
      // then is cut too: it was not a tag).
      const std::size_t at = last_space_ ? last_space_ : scanned_;
      if (!last_space_) depth_ = 0;
      cut(out, at);
    }
  }
}

}  // namespace facecast::server
