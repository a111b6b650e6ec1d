#include "facecast/core/random.hpp"

#include <sys/random.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>

#include "facecast/core/error.hpp"

namespace facecast {

void random_bytes(void* out, std::size_t n) {
  auto* p = static_cast<unsigned char*>(out);
  while (n > 0) {
    const ssize_t got = getrandom(p, n, 0);
    if (got < 0) {
      if (errno == EINTR) continue;
      throw Error(std::string("getrandom: ") + std::strerror(errno), ErrorCode::kInternal);
    }
    p += got;
    n -= static_cast<std::size_t>(got);
  }
}

std::string random_hex(std::size_t bytes) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string raw(bytes, '\0');
  random_bytes(raw.data(), bytes);
  std::string out;
  out.reserve(2 * bytes);
  for (const char c : raw) {
    const auto b = static_cast<unsigned char>(c);
    out += kHex[b >> 4];
    out += kHex[b & 15];
  }
  return out;
}

std::string time_ordered_hex() {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(
                      std::chrono::system_clock::now().time_since_epoch())
                      .count();
  char head[16];
  std::snprintf(head, sizeof head, "%012llx",
                static_cast<unsigned long long>(ms) & 0xFFFFFFFFFFFFULL);
  return head + random_hex(4);
}

}  // namespace facecast
