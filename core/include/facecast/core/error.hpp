#pragma once
// The one error policy of Facecast.
//
// Libraries throw facecast::Error for anything a user can cause (bad files, bad text, bad options);
// the message is one line that names the file, position or field. Anything else (std::bad_alloc,
// logic errors) is a bug. Async server paths carry the same information as an ErrorCode + message;
// the server turns both into protocol errors in one place, the CLI prints "facecast: <message>" and
// exits non-zero. Nothing in a library calls exit().
#include <stdexcept>
#include <string>
#include <string_view>

namespace facecast {

enum class ErrorCode {
  kInvalidInput,  // malformed file, text, option or message
  kNotFound,      // missing file, unknown rig or name
  kUnsupported,   // valid but not handled (e.g. an OBJ feature we do not read)
  kLimit,         // a configured limit was exceeded
  kInternal,      // a failure of a system resource (GL, ffmpeg, disk)
};

std::string_view to_string(ErrorCode code) noexcept;

class Error : public std::runtime_error {
 public:
  explicit Error(std::string message, ErrorCode code = ErrorCode::kInvalidInput)
      : std::runtime_error(std::move(message)), code_(code) {}
  ErrorCode code() const noexcept { return code_; }

 private:
  ErrorCode code_;
};

}  // namespace facecast
