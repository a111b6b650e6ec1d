#include "facecast/core/random.hpp"

#include <sys/random.h>

#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <unordered_set>

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
  // The random tails drawn in this process within the current millisecond: a tail drawn twice
  // is drawn again (32 random bits collide by chance among a few thousand ids in one
  // millisecond: the birthday bound).
  static std::mutex mutex;
  static long long last_ms = -1;
  static std::unordered_set<std::uint32_t> tails;
  std::uint32_t tail = 0;
  long long ms = 0;
  {
    const std::lock_guard lock(mutex);
    ms = std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
             .count();
    if (ms != last_ms) {
      tails.clear();
      last_ms = ms;
    }
    do random_bytes(&tail, sizeof tail);
    while (!tails.insert(tail).second);
  }
  char out[24];
  std::snprintf(out, sizeof out, "%012llx%08x",
                static_cast<unsigned long long>(ms) & 0xFFFFFFFFFFFFULL,
                static_cast<unsigned>(tail));
  return out;
}

}  // namespace facecast
