#include "bench_hostile.hpp"

#include <unistd.h>

#include <chrono>
#include <nlohmann/json.hpp>

#include "raw_client.hpp"

namespace bench {

using nlohmann::json;

bool Hostile::attack(int kind, const char* source, unsigned short port) {
  namespace raw = fctest::raw;
  if (kind == 0) return raw::ping_without_reading(source, port, 10) >= 0;
  if (kind == 1 || kind == 2 || kind == 5) {
    const int fd = raw::open_websocket(source, port, 4096);
    if (fd < 0) return true;  // refused: the per-address limit
    std::string frame;
    if (kind == 1) {
      frame = raw::client_frame(0x1, R"({"type":"ping","t":1})");
    } else if (kind == 2) {
      frame = raw::client_frame(
          0x1, json{{"type", "speak"},
                    {"id", "x"},
                    {"timestamps",
                     {{"format", "polly"}, {"data", R"({"time":0,"type":"viseme","value":"p"}
{"time":1000000000000,"type":"viseme","value":"a"})"}}}}
                   .dump());
    } else {
      raw::send_all(fd, raw::client_frame(0x1, json{{"type", "speak"},
                                                    {"id", "u"},
                                                    {"audio", false},
                                                    {"text", "Hello"},
                                                    {"more", true}}
                                                   .dump()));
      frame = raw::client_frame(
          0x1, json{{"type", "append"}, {"id", "u"}, {"text", std::string(1000, 'a')}}.dump());
    }
    const double closed = raw::flood_until_closed(fd, frame, 10);
    close(fd);
    return closed >= 0;
  }
  if (kind == 3) {
    std::vector<int> fds;
    for (int i = 0; i < 300; ++i)
      if (const int fd = raw::connect_from(source, port); fd >= 0) fds.push_back(fd);
    const bool refused = !fds.empty() && raw::read_head(fds.back(), 5).starts_with("HTTP/1.1 503");
    std::this_thread::sleep_for(std::chrono::seconds(2));
    for (const int fd : fds) close(fd);
    return refused;
  }
  const int fd = raw::connect_from(source, port);  // 4: a body announced, never sent
  if (fd < 0) return true;
  raw::send_all(fd,
                "POST /api/rigs HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: "
                "model/gltf-binary\r\nContent-Length: 67108864\r\n\r\nglTF");
  const bool answered = !raw::read_head(fd, 10).empty();  // 408/503 or closed at http_timeout
  close(fd);
  return answered;
}

}  // namespace bench
