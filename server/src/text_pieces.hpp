#pragma once
// Incremental text (docs/algorithms.md#incremental-text): which part of the text received so far
// can be spoken now. A piece ends after a sentence end (. ! ? ; or a line break, followed by
// white space, outside expression tags) or, for Chinese, after any clause mark (。！？；，、：).
#include <string>
#include <vector>

namespace facecast::server {

/// Removes the complete pieces from the front of `buffer` and returns them (trimmed, white-space
/// only pieces dropped). `final`: the text is closed, the rest is a piece too.
std::vector<std::string> take_pieces(std::string& buffer, bool final);

}  // namespace facecast::server
