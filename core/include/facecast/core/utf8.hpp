#pragma once
// UTF-8 validity: names read from files (OBJ groups and materials, file stems, glTF strings) must
// be valid UTF-8 before they reach JSON, GLB or the protocol.
#include <string_view>

namespace facecast {

/// True when `text` is well-formed UTF-8 (no overlong forms, surrogates or code points past
/// U+10FFFF).
bool is_valid_utf8(std::string_view text) noexcept;

}  // namespace facecast
