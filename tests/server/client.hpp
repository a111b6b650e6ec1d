#pragma once
// Test clients for the real server: HTTP requests and a facecast.v1 WebSocket client (Boost.Beast),
// every read bounded by a timeout, and a TestServer that runs facecast::server::Server in-process
// on an ephemeral port with its own data and web folders.
#include <chrono>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <nlohmann/json.hpp>

#include "facecast/server/options.hpp"
#include "facecast/server/protocol.hpp"
#include "facecast/server/server.hpp"

namespace fctest {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = net::ip::tcp;
using Headers = std::vector<std::pair<std::string, std::string>>;

/// An Authorization header carrying `key`.
inline Headers bearer(const std::string& key) {
  return {{"Authorization", "Bearer " + key}};
}
/// `h` with one more header.
inline Headers with(Headers h, const std::string& name, const std::string& value) {
  h.emplace_back(name, value);
  return h;
}

/// Timing tolerances grow under sanitizers (everything runs several times slower).
double slowdown();
/// False under ThreadSanitizer: there the server runs several times slower than real time, so the
/// checks of real-time behaviour (audio/video sync, frame pacing) are left out; the build is there
/// to find races, and the pipeline still runs whole.
bool real_time();

struct HttpResponse {
  int status = 0;
  std::map<std::string, std::string> headers;  // lower-case names
  std::string body;
  nlohmann::json json() const { return nlohmann::json::parse(body); }
  std::string header(const std::string& name) const {
    const auto it = headers.find(name);
    return it == headers.end() ? "" : it->second;
  }
};

/// One request on a fresh connection ("Connection: close").
HttpResponse http_request(unsigned short port, http::verb method, const std::string& target,
                          const std::string& body = {}, const Headers& headers = {},
                          double timeout = 30);
/// Sends raw bytes and returns whatever comes back until the server closes (for malformed
/// requests and targets that an HTTP library would normalise).
std::string raw_request(unsigned short port, const std::string& bytes, double timeout = 10);

/// A loopback port nothing listens on now (the kernel's pick, released again).
unsigned short free_port();

/// Polls GET /readyz every 50 ms until it answers 200 or `seconds` pass (a server warms up in
/// seconds, several times longer under a sanitizer: give 30 * slowdown()); whether it did.
bool wait_until_ready(unsigned short port, double seconds);

/// The producer token of the channel "show" that the channel tests configure.
inline const char* const kProducerToken = "producer-secret-1";

class WsClient {
 public:
  struct Options {
    std::string target = "/ws";
    Headers headers;
    std::string subprotocol = "facecast.v1";  // empty: none offered
    int receive_buffer = 0;                   // SO_RCVBUF before connecting (0: default)
  };
  struct Message {
    bool text = false;
    std::string data;
    std::chrono::steady_clock::time_point at;
    nlohmann::json json() const { return nlohmann::json::parse(data); }
  };

  /// Connects and completes the handshake; throws (with the HTTP status) when refused.
  WsClient(unsigned short port, Options options);
  explicit WsClient(unsigned short port) : WsClient(port, Options{}) {}
  /// The HTTP status of an upgrade attempt (101 when accepted).
  static int handshake_status(unsigned short port, Options options);

  void send(const std::string& text);
  void send(const nlohmann::json& j) { send(j.dump()); }
  /// One binary message.
  void send_binary(const std::string& bytes);
  /// The next message, or nullopt on timeout or close (see closed()).
  std::optional<Message> read(double timeout);
  /// The next text message, skipping binary ones; throws on timeout/close.
  nlohmann::json read_json(double timeout);
  bool closed() const { return closed_; }
  /// The close code the server sent (0 if none).
  int close_code() const { return close_code_; }
  std::string error() const { return error_; }
  /// Close politely.
  void close();
  const std::string& subprotocol() const { return negotiated_; }

 private:
  net::io_context ioc_;
  websocket::stream<beast::tcp_stream> ws_;
  beast::flat_buffer buffer_;
  bool closed_ = false;
  int close_code_ = 0;
  std::string error_, negotiated_;
};

/// Everything one stream delivered.
struct StreamResult {
  nlohmann::json start, end;
  std::optional<nlohmann::json> error;
  struct Weights {
    facecast::server::MediaHeader header;
    std::vector<float> values;
    std::chrono::steady_clock::time_point at;
  };
  std::vector<Weights> weights;
  struct Audio {
    facecast::server::MediaHeader header;
    std::size_t samples = 0;
    std::chrono::steady_clock::time_point at;
  };
  std::vector<Audio> audio;
  struct Frame {
    facecast::server::MediaHeader header;
    std::string jpeg;
    std::chrono::steady_clock::time_point at;
  };
  std::vector<Frame> frames;
  std::chrono::steady_clock::time_point start_at;
  std::vector<nlohmann::json> others;  // other text messages seen meanwhile
};

/// Reads until `stream_end` (or `error`) for utterance `id`; media of other streams are ignored.
/// `started`: the stream_start already read (to continue a stream part of which was read).
StreamResult collect_stream(WsClient& client, const std::string& id, double timeout = 60,
                            const nlohmann::json* started = nullptr);

/// The server in-process on 127.0.0.1 with an ephemeral port, a fresh data folder and a small web
/// folder (index.html, app.js, style/site.css; a secret.txt next to it and a symlink to it).
class TestServer {
 public:
  explicit TestServer(const std::function<void(facecast::server::ServerOptions&)>& tweak = {});
  ~TestServer();
  unsigned short port() const { return server_->port(); }
  facecast::server::Server& server() { return *server_; }
  const facecast::server::ServerOptions& options() const { return options_; }
  const std::filesystem::path& dir() const { return dir_; }
  /// Stops and starts again on the same data folder (new port).
  void restart();

 private:
  std::filesystem::path dir_;
  facecast::server::ServerOptions options_;
  std::unique_ptr<facecast::server::Server> server_;
};

/// The rigs every server lists first: the default avatar, and the shipped template when the build
/// packed it from ../shared/data (rigbuild/template.hpp).
nlohmann::json builtin_rig_ids();

/// The value of a metric line "name{labels} value" in /metrics text (or -1).
double metric_value(const std::string& metrics, const std::string& name_and_labels);

}  // namespace fctest
