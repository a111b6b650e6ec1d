#pragma once
// Incremental text (docs/algorithms.md#incremental-text): which part of the text received so far
// can be spoken now. A piece ends after a sentence end (. ! ? ; or a line break, followed by
// white space, outside expression tags) or, for Chinese, after any clause mark (。！？；，、：).
// A piece never grows past `max_piece` characters: a longer run is cut at its last space (or,
// without one, where it reached the limit), so no piece hands the synthesizer a long text at once.
//
// Each byte is scanned once however the text arrives (the scan resumes where it stopped), and the
// utterance's whole text is counted against `max_text`.
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace facecast::server {

class TextPieces {
 public:
  TextPieces(std::size_t max_text, std::size_t max_piece)
      : max_text_(max_text), max_piece_(max_piece) {}

  /// Adds `text` and returns the pieces it completed (trimmed, white-space-only pieces dropped).
  /// Throws RequestError (limit) naming `field` when the utterance's text would pass max_text
  /// characters; nothing is added then.
  std::vector<std::string> add(std::string_view text, std::string_view field);
  /// The text is closed: the rest is a piece too.
  std::vector<std::string> finish();
  /// Characters (code points) received so far.
  std::size_t characters() const noexcept { return characters_; }

 private:
  void scan(std::vector<std::string>& out, bool final);
  void cut(std::vector<std::string>& out, std::size_t at);

  std::size_t max_text_, max_piece_;
  std::size_t characters_ = 0;
  std::string buffer_;           // text not yet in a piece
  std::size_t scanned_ = 0;      // bytes of buffer_ already looked at
  std::size_t piece_chars_ = 0;  // characters of buffer_[0, scanned_)
  std::size_t last_space_ = 0;   // end of the last space at depth 0 in buffer_ (0: none)
  int depth_ = 0;                // inside an expression tag "(joy, 40, 0.5)"
};

}  // namespace facecast::server
