#include "client.hpp"

#include <boost/asio/connect.hpp>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <thread>

#include "facecast/rigbuild/template.hpp"
#include "sanitizers.hpp"
#include "test_data.hpp"

namespace fctest {
namespace {

std::chrono::steady_clock::duration seconds(double s) {
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(s));
}

// Runs one asynchronous operation to completion or until `timeout`, then cancels it.
template <class Start, class Cancel>
beast::error_code run_op(net::io_context& ioc, double timeout, Start start, Cancel cancel) {
  std::optional<beast::error_code> result;
  start([&result](beast::error_code ec, auto&&...) { result = ec; });
  ioc.restart();
  ioc.run_for(seconds(timeout));
  if (!result) {
    cancel();
    ioc.restart();
    ioc.run();
    return net::error::timed_out;
  }
  return *result;
}

void write_text(const std::filesystem::path& p, const std::string& text) {
  std::filesystem::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << text;
}

}  // namespace

bool wait_until_ready(unsigned short port, double seconds) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  for (;;) {
    try {
      if (http_request(port, http::verb::get, "/readyz", {}, {}, 5).status == 200) return true;
    } catch (const std::exception&) {  // not listening yet
    }
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

double slowdown() {
#if defined(FACECAST_TSAN)
  return 6.0;
#elif defined(FACECAST_ASAN)
  return 3.0;
#else
  return 1.0;
#endif
}

bool real_time() {
#if defined(FACECAST_TSAN)
  return false;
#else
  return true;
#endif
}

HttpResponse http_request(unsigned short port, http::verb method, const std::string& target,
                          const std::string& body, const Headers& headers, double timeout) {
  net::io_context ioc;
  beast::tcp_stream stream(ioc);
  stream.expires_after(seconds(timeout));
  stream.connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
  http::request<http::string_body> req{method, target, 11};
  req.set(http::field::host, "127.0.0.1:" + std::to_string(port));
  req.set(http::field::connection, "close");
  for (const auto& [k, v] : headers) req.set(k, v);
  if (!body.empty() || method == http::verb::post) {
    req.body() = body;
    req.prepare_payload();
  }
  beast::error_code ec;
  http::async_write(stream, req, [&](beast::error_code e, std::size_t) { ec = e; });
  ioc.run();
  if (ec) throw std::runtime_error("http write: " + ec.message());
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.body_limit(512u << 20);
  if (method == http::verb::head) parser.skip(true);
  ioc.restart();
  stream.expires_after(seconds(timeout));
  http::async_read(stream, buffer, parser, [&](beast::error_code e, std::size_t) { ec = e; });
  ioc.run();
  if (ec) throw std::runtime_error("http read " + target + ": " + ec.message());
  HttpResponse out;
  const auto& res = parser.get();
  out.status = static_cast<int>(res.result_int());
  for (const auto& f : res) {
    std::string name(f.name_string());
    for (auto& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    out.headers[name] = std::string(f.value());
  }
  out.body = res.body();
  return out;
}

unsigned short free_port() {
  net::io_context io;
  tcp::acceptor a(io, {net::ip::make_address("127.0.0.1"), 0});
  return a.local_endpoint().port();
}

std::string raw_request(unsigned short port, const std::string& bytes, double timeout) {
  net::io_context ioc;
  beast::tcp_stream stream(ioc);
  stream.expires_after(seconds(timeout));
  stream.connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
  net::write(stream.socket(), net::buffer(bytes));
  std::string out;
  std::array<char, 4096> buf;
  for (;;) {
    beast::error_code ec;
    std::size_t n = 0;
    stream.async_read_some(net::buffer(buf), [&](beast::error_code e, std::size_t k) {
      ec = e;
      n = k;
    });
    ioc.restart();
    ioc.run();
    out.append(buf.data(), n);
    if (ec) break;
  }
  return out;
}

WsClient::WsClient(unsigned short port, Options options) : ws_(ioc_) {
  auto& sock = beast::get_lowest_layer(ws_).socket();
  sock.open(tcp::v4());
  if (options.receive_buffer > 0)
    sock.set_option(net::socket_base::receive_buffer_size(options.receive_buffer));
  beast::get_lowest_layer(ws_).expires_after(std::chrono::seconds(10));
  beast::get_lowest_layer(ws_).connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
  beast::get_lowest_layer(ws_).expires_never();
  ws_.set_option(websocket::stream_base::decorator([options](websocket::request_type& req) {
    if (!options.subprotocol.empty())
      req.set(http::field::sec_websocket_protocol, options.subprotocol);
    for (const auto& [k, v] : options.headers) req.set(k, v);
  }));
  ws_.read_message_max(64u << 20);
  websocket::response_type res;
  const std::string host = "127.0.0.1:" + std::to_string(port);
  const auto ec = run_op(
      ioc_, 15,
      [&](auto handler) { ws_.async_handshake(res, host, options.target, std::move(handler)); },
      [&] { beast::get_lowest_layer(ws_).cancel(); });
  if (ec) {
    throw std::runtime_error("websocket handshake failed (" + ec.message() + "), HTTP " +
                             std::to_string(res.result_int()) + ": " + res.body());
  }
  negotiated_ = std::string(res[http::field::sec_websocket_protocol]);
}

int WsClient::handshake_status(unsigned short port, Options options) {
  net::io_context ioc;
  websocket::stream<beast::tcp_stream> ws(ioc);
  beast::get_lowest_layer(ws).connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
  ws.set_option(websocket::stream_base::decorator([options](websocket::request_type& req) {
    if (!options.subprotocol.empty())
      req.set(http::field::sec_websocket_protocol, options.subprotocol);
    for (const auto& [k, v] : options.headers) req.set(k, v);
  }));
  websocket::response_type res;
  const std::string host = "127.0.0.1:" + std::to_string(port);
  (void)run_op(
      ioc, 15,
      [&](auto handler) { ws.async_handshake(res, host, options.target, std::move(handler)); },
      [&] { beast::get_lowest_layer(ws).cancel(); });
  return static_cast<int>(res.result_int());
}

void WsClient::send(const std::string& text) {
  ws_.text(true);
  const auto ec = run_op(
      ioc_, 15, [&](auto handler) { ws_.async_write(net::buffer(text), std::move(handler)); },
      [&] { beast::get_lowest_layer(ws_).cancel(); });
  if (ec) throw std::runtime_error("websocket write: " + ec.message());
}

void WsClient::send_binary(const std::string& bytes) {
  ws_.binary(true);
  const auto ec = run_op(
      ioc_, 15, [&](auto handler) { ws_.async_write(net::buffer(bytes), std::move(handler)); },
      [&] { beast::get_lowest_layer(ws_).cancel(); });
  if (ec) throw std::runtime_error("websocket write: " + ec.message());
}

std::optional<WsClient::Message> WsClient::read(double timeout) {
  if (closed_) return std::nullopt;
  buffer_.consume(buffer_.size());
  const auto ec = run_op(
      ioc_, timeout, [&](auto handler) { ws_.async_read(buffer_, std::move(handler)); },
      [&] { beast::get_lowest_layer(ws_).cancel(); });
  if (ec == net::error::timed_out) {
    closed_ = true;  // a cancelled read leaves the stream unusable
    error_ = "timeout";
    return std::nullopt;
  }
  if (ec) {
    closed_ = true;
    error_ = ec.message();
    close_code_ = ws_.reason().code;
    return std::nullopt;
  }
  Message m;
  m.text = ws_.got_text();
  m.data = beast::buffers_to_string(buffer_.data());
  m.at = std::chrono::steady_clock::now();
  return m;
}

nlohmann::json WsClient::read_json(double timeout) {
  const auto deadline = std::chrono::steady_clock::now() + seconds(timeout);
  for (;;) {
    const double left =
        std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0) throw std::runtime_error("read_json: timeout");
    auto m = read(left);
    if (!m) throw std::runtime_error("read_json: " + error_);
    if (m->text) return m->json();
  }
}

void WsClient::close() {
  if (closed_) return;
  (void)run_op(
      ioc_, 5,
      [&](auto handler) { ws_.async_close(websocket::close_code::normal, std::move(handler)); },
      [&] { beast::get_lowest_layer(ws_).cancel(); });
  closed_ = true;
}

StreamResult collect_stream(WsClient& client, const std::string& id, double timeout,
                            const nlohmann::json* started) {
  using facecast::server::MediaKind;
  StreamResult r;
  std::optional<std::uint32_t> stream;
  if (started) {
    r.start = *started;
    stream = started->at("stream").get<std::uint32_t>();
  }
  const auto deadline = std::chrono::steady_clock::now() + seconds(timeout);
  for (;;) {
    const double left =
        std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0) throw std::runtime_error("collect_stream " + id + ": timeout");
    auto m = client.read(left);
    if (!m) throw std::runtime_error("collect_stream " + id + ": " + client.error());
    if (m->text) {
      auto j = m->json();
      const std::string type = j.value("type", "");
      const bool ours = j.contains("id") && j["id"].is_string() && j["id"] == id;
      if (type == "stream_start" && ours) {
        r.start = j;
        r.start_at = m->at;
        stream = j["stream"].get<std::uint32_t>();
      } else if (type == "stream_end" && ours) {
        r.end = j;
        return r;
      } else if (type == "error" && ours) {
        r.error = j;
        if (!stream) return r;
      } else {
        r.others.push_back(j);
      }
      continue;
    }
    const auto h = facecast::server::read_header(m->data);
    if (!stream || h.stream != *stream) continue;
    const std::string_view payload =
        std::string_view(m->data).substr(facecast::server::kHeaderSize);
    if (h.kind == MediaKind::kWeights) {
      r.weights.push_back({h, facecast::server::read_floats(payload), m->at});
    } else if (h.kind == MediaKind::kAudio) {
      if (payload.size() != h.count * 2u) throw std::runtime_error("audio payload size");
      r.audio.push_back({h, h.count, m->at});
    } else {
      r.frames.push_back({h, std::string(payload), m->at});
    }
  }
}

TestServer::TestServer(const std::function<void(facecast::server::ServerOptions&)>& tweak) {
  static int counter = 0;
  dir_ = facecast::test::scratch_dir() / ("server" + std::to_string(++counter));
  std::filesystem::create_directories(dir_);
  write_text(dir_ / "web" / "index.html", "<!doctype html><title>facecast test</title>\n");
  write_text(dir_ / "web" / "app.js", "export const answer = 42;\n");
  write_text(dir_ / "web" / "style" / "site.css", "body { color: black; }\n");
  write_text(dir_ / "web" / ".hidden", "HIDDEN-CONTENT\n");
  write_text(dir_ / "secret.txt", "TOP-SECRET\n");
  std::error_code ec;
  std::filesystem::create_symlink(dir_ / "secret.txt", dir_ / "web" / "link.txt", ec);
  options_.port = 0;
  options_.data = dir_ / "data";
  options_.web_root = dir_ / "web";
  const char* level = std::getenv("FACECAST_TEST_LOG");
  options_.log_level = level ? level : "warn";
  if (tweak) tweak(options_);
  server_ = std::make_unique<facecast::server::Server>(options_);
  server_->start();
}

TestServer::~TestServer() {
  if (server_) {
    server_->stop();
    server_->wait();
  }
}

void TestServer::restart() {
  server_->stop();
  server_->wait();
  server_.reset();
  server_ = std::make_unique<facecast::server::Server>(options_);
  server_->start();
}

double metric_value(const std::string& metrics, const std::string& name_and_labels) {
  const std::string key = name_and_labels + " ";
  std::size_t pos = 0;
  while ((pos = metrics.find(key, pos)) != std::string::npos) {
    if (pos == 0 || metrics[pos - 1] == '\n') return std::stod(metrics.substr(pos + key.size()));
    pos += key.size();
  }
  return -1;
}

nlohmann::json builtin_rig_ids() {
  nlohmann::json ids = {"default"};
  std::error_code ec;
  try {
    if (std::filesystem::exists(facecast::rigbuild::shipped_template_path(), ec))
      ids.push_back(facecast::rigbuild::kShippedTemplateId);
  } catch (const std::exception&) {  // not built: no shared data
  }
  return ids;
}

}  // namespace fctest
