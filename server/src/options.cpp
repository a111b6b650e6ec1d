#include "facecast/server/options.hpp"

#include <boost/asio/ip/address.hpp>
#include <cmath>
#include <functional>
#include <map>

#include "facecast/core/config.hpp"
#include "facecast/core/error.hpp"

namespace facecast::server {
namespace {

using nlohmann::json;

template <class T>
void read_int(const json& v, const std::string& where, T& out) {
  if (!v.is_number_integer()) throw Error(where + ": expected an integer");
  const auto x = v.get<long long>();
  if (x < 0) throw Error(where + ": must not be negative");
  out = static_cast<T>(x);
}

void read_double(const json& v, const std::string& where, double& out) {
  if (!v.is_number()) throw Error(where + ": expected a number");
  out = v.get<double>();
}

void read_string(const json& v, const std::string& where, std::string& out) {
  if (!v.is_string()) throw Error(where + ": expected a string");
  out = v.get<std::string>();
}

void read_path(const json& v, const std::string& where, std::filesystem::path& out) {
  std::string s;
  read_string(v, where, s);
  out = s;
}

}  // namespace

bool is_loopback_host(const std::string& host) {
  if (host == "localhost") return true;
  boost::system::error_code ec;
  const auto addr = boost::asio::ip::make_address(host, ec);
  return !ec && addr.is_loopback();
}

ServerOptions load_server_options(const std::filesystem::path& path) {
  const json j = load_json(path);
  const std::string file = path.filename().string();
  if (!j.is_object()) throw Error(file + ": expected a JSON object");
  ServerOptions o;
  using Setter = std::function<void(const json&, const std::string&)>;
  const std::map<std::string, Setter> setters = {
      {"host", [&](const json& v, const std::string& w) { read_string(v, w, o.host); }},
      {"port", [&](const json& v, const std::string& w) { read_int(v, w, o.port); }},
      {"data", [&](const json& v, const std::string& w) { read_path(v, w, o.data); }},
      {"token", [&](const json& v, const std::string& w) { read_string(v, w, o.token); }},
      {"web_root", [&](const json& v, const std::string& w) { read_path(v, w, o.web_root); }},
      {"three_root", [&](const json& v, const std::string& w) { read_path(v, w, o.three_root); }},
      {"default_rig",
       [&](const json& v, const std::string& w) { read_string(v, w, o.default_rig); }},
      {"io_threads", [&](const json& v, const std::string& w) { read_int(v, w, o.io_threads); }},
      {"workers", [&](const json& v, const std::string& w) { read_int(v, w, o.workers); }},
      {"job_workers", [&](const json& v, const std::string& w) { read_int(v, w, o.job_workers); }},
      {"max_connections",
       [&](const json& v, const std::string& w) { read_int(v, w, o.max_connections); }},
      {"max_message", [&](const json& v, const std::string& w) { read_int(v, w, o.max_message); }},
      {"max_text", [&](const json& v, const std::string& w) { read_int(v, w, o.max_text); }},
      {"max_body", [&](const json& v, const std::string& w) { read_int(v, w, o.max_body); }},
      {"max_upload", [&](const json& v, const std::string& w) { read_int(v, w, o.max_upload); }},
      {"speak_per_minute",
       [&](const json& v, const std::string& w) { read_double(v, w, o.speak_per_minute); }},
      {"speak_burst", [&](const json& v, const std::string& w) { read_int(v, w, o.speak_burst); }},
      {"max_queued_speaks",
       [&](const json& v, const std::string& w) { read_int(v, w, o.max_queued_speaks); }},
      {"max_fps", [&](const json& v, const std::string& w) { read_int(v, w, o.max_fps); }},
      {"max_frame_side",
       [&](const json& v, const std::string& w) { read_int(v, w, o.max_frame_side); }},
      {"max_jobs", [&](const json& v, const std::string& w) { read_int(v, w, o.max_jobs); }},
      {"max_render_seconds",
       [&](const json& v, const std::string& w) { read_double(v, w, o.max_render_seconds); }},
      {"lead", [&](const json& v, const std::string& w) { read_double(v, w, o.lead); }},
      {"min_tick", [&](const json& v, const std::string& w) { read_double(v, w, o.min_tick); }},
      {"audio_chunk",
       [&](const json& v, const std::string& w) { read_double(v, w, o.audio_chunk); }},
      {"cancel_fade",
       [&](const json& v, const std::string& w) { read_double(v, w, o.cancel_fade); }},
      {"write_queue", [&](const json& v, const std::string& w) { read_int(v, w, o.write_queue); }},
      {"slow_client_grace",
       [&](const json& v, const std::string& w) { read_double(v, w, o.slow_client_grace); }},
      {"close_timeout",
       [&](const json& v, const std::string& w) { read_double(v, w, o.close_timeout); }},
      {"frames_in_flight",
       [&](const json& v, const std::string& w) { read_int(v, w, o.frames_in_flight); }},
      {"jpeg_quality",
       [&](const json& v, const std::string& w) { read_int(v, w, o.jpeg_quality); }},
      {"render_contexts",
       [&](const json& v, const std::string& w) { read_int(v, w, o.render_contexts); }},
      {"max_renderers",
       [&](const json& v, const std::string& w) { read_int(v, w, o.max_renderers); }},
      {"send_buffer", [&](const json& v, const std::string& w) { read_int(v, w, o.send_buffer); }},
      {"http_timeout",
       [&](const json& v, const std::string& w) { read_double(v, w, o.http_timeout); }},
      {"ws_handshake_timeout",
       [&](const json& v, const std::string& w) { read_double(v, w, o.ws_handshake_timeout); }},
      {"ws_idle_timeout",
       [&](const json& v, const std::string& w) { read_double(v, w, o.ws_idle_timeout); }},
      {"shutdown_timeout",
       [&](const json& v, const std::string& w) { read_double(v, w, o.shutdown_timeout); }},
      {"allowed_origins",
       [&](const json& v, const std::string& w) {
         if (!v.is_array()) throw Error(w + ": expected an array of origins");
         o.allowed_origins.clear();
         for (const auto& x : v) {
           if (!x.is_string()) throw Error(w + ": expected an array of origins");
           o.allowed_origins.push_back(x.get<std::string>());
         }
       }},
      {"log_level", [&](const json& v, const std::string& w) { read_string(v, w, o.log_level); }},
  };
  for (const auto& [key, value] : j.items()) {
    if (key.starts_with("_")) continue;  // comments
    const auto it = setters.find(key);
    if (it == setters.end()) throw Error(file + ": unknown key '" + key + "'");
    it->second(value, file + ": " + key);
  }
  validate(o);
  return o;
}

void validate(const ServerOptions& o) {
  auto need = [](bool ok, const std::string& what) {
    if (!ok) throw Error(what);
  };
  need(!o.host.empty(), "host: empty");
  need(o.port >= 0 && o.port <= 65535, "port: must be in 0..65535");
  need(o.io_threads >= 1 && o.io_threads <= 64, "io_threads: must be in 1..64");
  need(o.workers >= 1 && o.workers <= 64, "workers: must be in 1..64");
  need(o.job_workers >= 1 && o.job_workers <= 16, "job_workers: must be in 1..16");
  need(o.max_connections >= 1, "max_connections: must be at least 1");
  need(o.max_message >= 256, "max_message: must be at least 256 bytes");
  need(o.max_text >= 1, "max_text: must be at least 1");
  need(o.max_body >= 256, "max_body: must be at least 256 bytes");
  need(o.max_upload >= 1024, "max_upload: must be at least 1024 bytes");
  need(o.speak_per_minute > 0, "speak_per_minute: must be positive");
  need(o.speak_burst >= 1, "speak_burst: must be at least 1");
  need(o.max_queued_speaks >= 1, "max_queued_speaks: must be at least 1");
  need(o.max_fps >= 1 && o.max_fps <= 1000, "max_fps: must be in 1..1000");
  need(o.max_frame_side >= 16 && o.max_frame_side <= 8192, "max_frame_side: must be in 16..8192");
  need(o.max_jobs >= 1, "max_jobs: must be at least 1");
  need(o.max_render_seconds > 0, "max_render_seconds: must be positive");
  need(o.lead >= 0 && o.lead <= 10, "lead: must be in 0..10 seconds");
  need(o.min_tick >= 0 && o.min_tick <= 1, "min_tick: must be in 0..1 seconds");
  need(o.audio_chunk >= 0.01 && o.audio_chunk <= 10, "audio_chunk: must be in 0.01..10 seconds");
  need(o.cancel_fade >= 0 && o.cancel_fade <= 5, "cancel_fade: must be in 0..5 seconds");
  need(o.write_queue >= 2, "write_queue: must be at least 2");
  need(o.slow_client_grace > 0, "slow_client_grace: must be positive");
  need(o.close_timeout > 0, "close_timeout: must be positive");
  need(o.frames_in_flight >= 1 && o.frames_in_flight <= 16, "frames_in_flight: must be in 1..16");
  need(o.jpeg_quality >= 1 && o.jpeg_quality <= 100, "jpeg_quality: must be in 1..100");
  need(o.render_contexts >= 1 && o.render_contexts <= 16, "render_contexts: must be in 1..16");
  need(o.max_renderers >= 1, "max_renderers: must be at least 1");
  need(o.send_buffer >= 0, "send_buffer: must not be negative");
  need(o.http_timeout > 0, "http_timeout: must be positive");
  need(o.ws_handshake_timeout > 0, "ws_handshake_timeout: must be positive");
  need(o.ws_idle_timeout > 0, "ws_idle_timeout: must be positive");
  need(o.shutdown_timeout > 0, "shutdown_timeout: must be positive");
  need(o.log_level == "debug" || o.log_level == "info" || o.log_level == "warn" ||
           o.log_level == "error",
       "log_level: '" + o.log_level + "' is not debug, info, warn or error");
  need(!o.default_rig.empty(), "default_rig: empty");
  if (!is_loopback_host(o.host) && o.token.empty()) {
    throw Error("host " + o.host +
                " is not a loopback address: set a token (--token, FACECAST_TOKEN or \"token\" in "
                "the config) so that only your clients can connect");
  }
}

}  // namespace facecast::server
