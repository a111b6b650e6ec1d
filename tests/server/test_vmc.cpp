// A private speak mirrored to a VMC receiver of the server's vmc_targets allow-list: a UDP socket
// gets one OSC bundle per frame at the frames' times; a name that is not on the list, an address,
// frames output and a channel's speak are refused and send nothing.
#include <atomic>
#include <boost/asio/ip/udp.hpp>
#include <catch2/catch.hpp>
#include <thread>

#include "client.hpp"

using namespace fctest;
using udp = boost::asio::ip::udp;

namespace {

using Clock = std::chrono::steady_clock;

// Collects the datagrams sent to a loopback port, with their arrival times.
class UdpReceiver {
 public:
  UdpReceiver() : socket_(io_, udp::endpoint(boost::asio::ip::make_address("127.0.0.1"), 0)) {
    socket_.non_blocking(true);
    socket_.set_option(udp::socket::receive_buffer_size(1 << 20));  // (capped by rmem_max)
  }
  unsigned short port() const { return socket_.local_endpoint().port(); }

  // Everything that arrives within `seconds`, or, once `done` is set, until the socket has been
  // quiet for half a second (a sanitizer build may send the last frames after the stream ended).
  std::vector<std::pair<Clock::time_point, std::string>> collect(
      double seconds, const std::atomic<bool>* done = nullptr) {
    std::vector<std::pair<Clock::time_point, std::string>> out;
    const auto until = Clock::now() + std::chrono::duration<double>(seconds);
    auto last = Clock::now();
    std::array<char, 65536> buf;
    while (Clock::now() < until) {
      if (done && *done && Clock::now() - last > std::chrono::milliseconds(500)) break;
      boost::system::error_code ec;
      const std::size_t n = socket_.receive(boost::asio::buffer(buf), 0, ec);
      if (ec == boost::asio::error::would_block) {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        continue;
      }
      if (ec) break;  // (no assertion here: it runs on a thread of its own)
      last = Clock::now();
      out.emplace_back(last, std::string(buf.data(), n));
    }
    return out;
  }

 private:
  boost::asio::io_context io_;
  udp::socket socket_;
};

nlohmann::json error_for(WsClient& c, const std::string& id) {
  for (int i = 0; i < 20; ++i) {
    const auto j = c.read_json(10);
    if (j["type"] == "error" && j["id"] == id) return j;
  }
  FAIL("no error for " << id);
  return {};
}

}  // namespace

TEST_CASE("a private speak plays to a VMC receiver the server allows, and nowhere else",
          "[ws][vmc]") {
  UdpReceiver receiver;
  TestServer server([&](facecast::server::ServerOptions& o) {
    o.vmc_targets["studio"].targets = {"127.0.0.1:" + std::to_string(receiver.port())};
    o.channels.push_back({"show", "producer-secret-1", "default", {}});
    o.channel_idle = 0;
  });
  WsClient c(server.port());
  REQUIRE(c.read_json(10)["type"] == "hello");

  // Refused: a name the server does not list, an address, frames, a channel's speak.
  c.send(nlohmann::json{{"type", "speak"}, {"id", "a"}, {"text", "hi"}, {"vmc", "nowhere"}});
  CHECK_THAT(error_for(c, "a")["message"].get<std::string>(),
             Catch::Contains("vmc: 'nowhere' is not one of the server's vmc_targets"));
  c.send(nlohmann::json{{"type", "speak"}, {"id", "b"}, {"text", "hi"}, {"vmc", "10.0.0.1:39539"}});
  CHECK_THAT(error_for(c, "b")["message"].get<std::string>(), Catch::Contains("vmc"));
  c.send(nlohmann::json{
      {"type", "speak"}, {"id", "c"}, {"text", "hi"}, {"vmc", "studio"}, {"output", "frames"}});
  CHECK_THAT(error_for(c, "c")["message"].get<std::string>(),
             Catch::Contains("a VMC receiver takes weights"));
  c.send(nlohmann::json{{"type", "produce"}, {"channel", "show"}, {"token", "producer-secret-1"}});
  c.send(nlohmann::json{
      {"type", "speak"}, {"id", "d"}, {"channel", "show"}, {"text", "hi"}, {"vmc", "studio"}});
  CHECK_THAT(error_for(c, "d")["message"].get<std::string>(), Catch::Contains("channels.show.vmc"));
  CHECK(receiver.collect(0.3).empty());

  // Allowed: every frame reaches the receiver as one bundle, paced over the utterance.
  std::vector<std::pair<Clock::time_point, std::string>> got;
  std::atomic<bool> ended{false};
  std::thread listen([&] { got = receiver.collect(60, &ended); });
  c.send(nlohmann::json{
      {"type", "speak"}, {"id", "v1"}, {"text", "Hello, papa. Open wide."}, {"vmc", "studio"}});
  const StreamResult r = collect_stream(c, "v1", 60);
  ended = true;
  listen.join();
  REQUIRE_FALSE(r.error);
  const auto frames = r.start["frames"].get<int>();
  const double duration = r.start["duration"].get<double>();
  CHECK(static_cast<int>(got.size()) == frames);
  REQUIRE(got.size() > 20);
  int with_jaw = 0;
  for (const auto& [at, bytes] : got) {
    CHECK(bytes.starts_with(std::string("#bundle\0", 8)));
    with_jaw += bytes.find("/VMC/Ext/Blend/Val") != std::string::npos &&
                bytes.find("jawOpen") != std::string::npos;
  }
  CHECK(with_jaw == static_cast<int>(got.size()));
  // Paced at the frame rate, not sent in the stream's first burst.
  const double spread = std::chrono::duration<double>(got.back().first - got.front().first).count();
  INFO("bundles over " << spread << " s for " << duration << " s");
  CHECK(spread > 0.8 * duration);
}
