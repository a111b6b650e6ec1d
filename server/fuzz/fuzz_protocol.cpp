// libFuzzer target: the facecast.v1 client message parser and the binary header reader.
// Build with -DFACECAST_FUZZ=ON -DCMAKE_CXX_COMPILER=clang++; run ./fuzz_protocol
// -max_total_time=60 Anything but facecast::Error (a crash, a sanitizer report, another exception)
// is a bug.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "facecast/core/error.hpp"
#include "facecast/server/protocol.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace facecast::server;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  ProtocolLimits limits;
  limits.max_text = 200;
  std::string id;
  try {
    const ClientMessage m = parse_client_message(text, limits, &id);
    // What the server then sends back must serialize (valid UTF-8 or replaced).
    if (const auto* ping = std::get_if<PingRequest>(&m)) (void)ping->t.dump();
    (void)error_message(id.empty() ? std::nullopt : std::optional<std::string>(id),
                        Problem{Code::kInvalidInput, std::string(text.substr(0, 64)), 400});
  } catch (const facecast::Error& e) {
    (void)describe(std::make_exception_ptr(e));
  }
  try {
    const MediaHeader h = read_header(text);
    std::string out(kHeaderSize, '\0');
    write_header(h, out.data());
    if (out.substr(4) != text.substr(4, kHeaderSize - 4)) __builtin_trap();  // round trip
  } catch (const facecast::Error&) {
  }
  return 0;
}
