#include "routes.hpp"

#include <ctime>
#include <regex>

#include "api.hpp"
#include "channel.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/subprocess.hpp"
#include "log.hpp"
#include "operations_api.hpp"
#include "photo_api.hpp"

namespace facecast::server {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

std::optional<std::string> percent_decode(std::string_view s, bool plus_is_space) {
  std::string out;
  out.reserve(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    if (c == '%') {
      if (i + 2 >= s.size()) return std::nullopt;
      const int hi = hex_digit(s[i + 1]);
      const int lo = hex_digit(s[i + 2]);
      if (hi < 0 || lo < 0) return std::nullopt;
      const char d = static_cast<char>(hi * 16 + lo);
      if (d == '\0') return std::nullopt;
      out += d;
      i += 2;
    } else if (c == '+' && plus_is_space) {
      out += ' ';
    } else if (c == '\0') {
      return std::nullopt;
    } else {
      out += c;
    }
  }
  return out;
}

std::string http_date(std::chrono::system_clock::time_point t) {
  const std::time_t secs = std::chrono::system_clock::to_time_t(t);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[64];
  std::strftime(buf, sizeof buf, "%a, %d %b %Y %H:%M:%S GMT", &tm);
  return buf;
}

std::optional<std::time_t> parse_http_date(std::string_view s) {
  std::tm tm{};
  const std::string str(s);
  const char* end = strptime(str.c_str(), "%a, %d %b %Y %H:%M:%S GMT", &tm);
  if (!end) return std::nullopt;
  return timegm(&tm);
}

}  // namespace

bool constant_time_equal(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  unsigned char diff = 0;
  for (std::size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ b[i]);
  return diff == 0;
}

namespace {

void count_status(State& state, unsigned status) {
  if (status >= 100 && status < state.metrics.http_responses_by_code.size())
    state.metrics.http_responses_by_code[status].fetch_add(1);
}

template <class Body>
http::message_generator finish(State& state, http::response<Body>&& res) {
  count_status(state, res.result_int());
  res.set(http::field::server, "facecast");
  res.prepare_payload();
  return http::message_generator(std::move(res));
}

}  // namespace

http::message_generator json_response(State& state, const Request& req, http::status status,
                                      const json& body) {
  http::response<http::string_body> res{status, req.version()};
  res.set(http::field::content_type, "application/json");
  res.set(http::field::cache_control, "no-store");
  res.keep_alive(req.keep_alive());
  if (req.method() != http::verb::head)
    res.body() = body.dump(-1, ' ', false, json::error_handler_t::replace) + "\n";
  return finish(state, std::move(res));
}

namespace {

// A file on disk with ETag / Last-Modified and conditional GET.
http::message_generator send_path(State& state, const Request& req, const fs::path& path,
                                  std::string_view content_type, std::string_view cache) {
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  if (ec) throw Error("not found", ErrorCode::kNotFound);
  const auto mtime = fs::last_write_time(path, ec);
  if (ec) throw Error("not found", ErrorCode::kNotFound);
  const auto sys = std::chrono::file_clock::to_sys(mtime);
  const auto ns =
      std::chrono::duration_cast<std::chrono::nanoseconds>(sys.time_since_epoch()).count();
  char etag[64];
  std::snprintf(etag, sizeof etag, "\"%llx-%llx\"", static_cast<unsigned long long>(size),
                static_cast<unsigned long long>(ns));
  const std::string last_modified =
      http_date(std::chrono::time_point_cast<std::chrono::system_clock::duration>(sys));

  bool not_modified = false;
  if (req.count(http::field::if_none_match)) {
    const auto inm = req[http::field::if_none_match];
    not_modified = inm == "*" || inm.find(etag) != std::string_view::npos;
  } else if (req.count(http::field::if_modified_since)) {
    const auto since = parse_http_date(req[http::field::if_modified_since]);
    not_modified =
        since &&
        std::chrono::system_clock::to_time_t(
            std::chrono::time_point_cast<std::chrono::system_clock::duration>(sys)) <= *since;
  }
  auto headers = [&](auto& res) {
    res.set(http::field::etag, etag);
    res.set(http::field::last_modified, last_modified);
    res.set(http::field::cache_control, cache);
    res.set("X-Content-Type-Options", "nosniff");
    res.keep_alive(req.keep_alive());
  };
  if (not_modified) {
    http::response<http::empty_body> res{http::status::not_modified, req.version()};
    headers(res);
    count_status(state, 304);
    res.set(http::field::server, "facecast");
    return http::message_generator(std::move(res));
  }
  if (req.method() == http::verb::head) {
    http::response<http::empty_body> res{http::status::ok, req.version()};
    headers(res);
    res.set(http::field::content_type, content_type);
    res.content_length(size);
    count_status(state, 200);
    res.set(http::field::server, "facecast");
    return http::message_generator(std::move(res));
  }
  http::file_body::value_type body;
  beast::error_code bec;
  body.open(path.c_str(), beast::file_mode::scan, bec);
  if (bec) throw Error("not found", ErrorCode::kNotFound);
  set_cloexec(body.file().native_handle());  // Beast opens without O_CLOEXEC
  http::response<http::file_body> res{std::piecewise_construct, std::make_tuple(std::move(body)),
                                      std::make_tuple(http::status::ok, req.version())};
  headers(res);
  res.set(http::field::content_type, content_type);
  return finish(state, std::move(res));
}

void require_method(const Request& req, std::initializer_list<http::verb> allowed) {
  for (const auto v : allowed)
    if (req.method() == v) return;
  std::string names;
  for (const auto v : allowed)
    names += (names.empty() ? "" : ", ") + std::string(http::to_string(v));
  throw RequestError(Code::kMethod,
                     std::string(req.method_string()) + " is not allowed here (" + names + ")");
}

// ---- API routes
// ----------------------------------------------------------------------------------

const std::regex kRigGlb("/api/rigs/([A-Za-z0-9_.-]{1,64})\\.glb");
const std::regex kRigEdges("/api/rigs/([A-Za-z0-9_.-]{1,64})/virtual_edges\\.json");
// Job ids: "j" + 20 hex digits (jobs.hpp), "j" + a number with Redis or from older stores.
const std::regex kJob("/api/jobs/(j[0-9a-f]{1,24})");
const std::regex kRig("/api/rigs/([A-Za-z0-9_.-]{1,64})");
const std::regex kJobFile("/api/jobs/(j[0-9a-f]{1,24})/(video\\.mp4)");

http::message_generator api(State& state, Request& req, const Target& t) {
  std::smatch m;
  const std::string& path = t.path;
  if (path == "/api/rigs") {
    if (req.method() == http::verb::post) return post_rig(state, req, t);
    require_method(req, {http::verb::get, http::verb::head, http::verb::post});
    json rigs = json::array();
    for (const auto& r : state.rigs.list()) rigs.push_back(r.to_json());
    return json_response(state, req, http::status::ok,
                         {{"rigs", rigs}, {"default", state.options.default_rig}});
  }
  if (path == "/api/photo") {
    require_method(req, {http::verb::post});
    return post_photo(state, req);
  }
  if (path == "/api/photo/landmarks") {
    require_method(req, {http::verb::post});
    return post_photo_landmarks(state, req);
  }
  if (path == "/api/landmarks") {
    require_method(req, {http::verb::post});
    return post_landmarks(state, req);
  }
  if (path == "/api/render") {
    require_method(req, {http::verb::post});
    return post_render(state, req);
  }
  if (path == "/api/audio") {
    require_method(req, {http::verb::post});
    return post_audio(state, req);
  }
  if (std::regex_match(path, m, kRigGlb)) {
    require_method(req, {http::verb::get, http::verb::head});
    const std::string id = m[1];
    if (!state.existing_rig(id).builtin || !state.rigs.glb_path(id).empty())
      return send_path(state, req, state.rigs.glb_path(id), "model/gltf-binary", "no-cache");
    const auto bytes = state.rigs.builtin_glb();
    const std::string etag =
        "\"default-" FACECAST_VERSION "-" + std::to_string(bytes->size()) + "\"";
    if (req[http::field::if_none_match] == etag) {
      http::response<http::empty_body> res{http::status::not_modified, req.version()};
      res.set(http::field::etag, etag);
      res.keep_alive(req.keep_alive());
      count_status(state, 304);
      return http::message_generator(std::move(res));
    }
    http::response<http::string_body> res{http::status::ok, req.version()};
    res.set(http::field::content_type, "model/gltf-binary");
    res.set(http::field::etag, etag);
    res.set(http::field::cache_control, "no-cache");
    res.keep_alive(req.keep_alive());
    if (req.method() == http::verb::head) {
      res.content_length(bytes->size());
      count_status(state, 200);
      return http::message_generator(std::move(res));
    }
    res.body() = *bytes;
    return finish(state, std::move(res));
  }
  if (std::regex_match(path, m, kRigEdges)) {
    require_method(req, {http::verb::get, http::verb::head});
    const std::string id = m[1];
    if (!state.existing_rig(id).virtual_edges)
      throw Error("rig '" + id + "' has no virtual edges", ErrorCode::kNotFound);
    return send_path(state, req, state.rigs.virtual_edges_path(id), "application/json", "no-cache");
  }
  if (std::regex_match(path, m, kJob)) {
    if (req.method() == http::verb::delete_) return delete_job(state, req, m[1]);
    require_method(req, {http::verb::get, http::verb::head, http::verb::delete_});
    const auto job = state.jobs.get(m[1]);
    if (!job) throw Error("job '" + std::string(m[1]) + "' does not exist", ErrorCode::kNotFound);
    return json_response(state, req, http::status::ok, *job);
  }
  if (std::regex_match(path, m, kRig) && !path.ends_with(".glb")) {
    require_method(req, {http::verb::delete_});
    return delete_rig(state, req, m[1]);
  }
  if (std::regex_match(path, m, kJobFile)) {
    require_method(req, {http::verb::get, http::verb::head});
    const auto file = state.jobs.file(m[1], m[2]);
    if (!file)
      throw Error("job '" + std::string(m[1]) + "' has no " + std::string(m[2]) + " (yet)",
                  ErrorCode::kNotFound);
    return send_path(state, req, *file, mime_type(m[2].str()), "no-cache");
  }
  throw Error("no API endpoint " + path, ErrorCode::kNotFound);
}

}  // namespace

Target parse_target(std::string_view target) {
  Target t;
  const auto q = target.find('?');
  const auto decoded = percent_decode(target.substr(0, q), false);
  if (!decoded || decoded->empty() || decoded->front() != '/') {
    t.valid = false;
    return t;
  }
  t.path = *decoded;
  if (q != std::string_view::npos) t.query = std::string(target.substr(q + 1));
  return t;
}

std::optional<std::string> query_value(std::string_view query, std::string_view key) {
  while (!query.empty()) {
    const auto amp = query.find('&');
    const std::string_view item = query.substr(0, amp);
    const auto eq = item.find('=');
    if (item.substr(0, eq) == key)
      return percent_decode(eq == std::string_view::npos ? "" : item.substr(eq + 1), true);
    if (amp == std::string_view::npos) break;
    query.remove_prefix(amp + 1);
  }
  return std::nullopt;
}

std::optional<std::string> request_token(const Request& req, const Target& target) {
  const auto auth = req[http::field::authorization];
  if (auth.size() > 7 && beast::iequals(auth.substr(0, 7), "Bearer "))
    return std::string(auth.substr(7));
  return query_value(target.query, "token");
}

bool token_ok(const State& state, const Request& req, const Target& target) {
  const std::string& token = state.options.token;
  if (token.empty()) return true;
  const auto given = request_token(req, target);
  return given && constant_time_equal(*given, token);
}

bool origin_ok(const State& state, const Request& req) {
  if (!req.count(http::field::origin)) return true;  // not a browser
  const std::string_view origin = req[http::field::origin];
  for (const auto& allowed : state.options.allowed_origins) {
    if (allowed == "*" || beast::iequals(allowed, origin)) return true;
  }
  const std::string_view host = req[http::field::host];
  if (host.empty()) return false;
  for (const std::string_view scheme : {"http://", "https://"}) {
    if (origin.size() == scheme.size() + host.size() &&
        beast::iequals(origin.substr(0, scheme.size()), scheme) &&
        beast::iequals(origin.substr(scheme.size()), host))
      return true;
  }
  return false;
}

std::size_t body_limit(const State& state, const Request& req) {
  if (req.method() == http::verb::post) {
    const auto t = parse_target(req.target());
    if (t.path == "/api/rigs" || t.path == "/api/render" || t.path == "/api/audio" ||
        t.path == "/api/photo" || t.path == "/api/photo/landmarks")
      return state.options.max_upload;
  }
  return state.options.max_body;
}

bool is_heavy(const Request& req) {
  if (req.method() == http::verb::post || req.method() == http::verb::delete_) return true;
  return req.target().starts_with("/api/rigs/");
}

http::message_generator error_response(State& state, unsigned version, bool keep_alive,
                                       const Problem& problem) {
  http::response<http::string_body> res{static_cast<http::status>(problem.status), version};
  res.set(http::field::content_type, "application/json");
  res.set(http::field::cache_control, "no-store");
  if (problem.status == 401) res.set(http::field::www_authenticate, "Bearer");
  res.keep_alive(keep_alive);
  res.body() = error_body(problem) + "\n";
  return finish(state, std::move(res));
}

http::message_generator handle_request(State& state, Request&& req) {
  try {
    const Target t = parse_target(req.target());
    if (!t.valid) throw Error("bad request target");
    const std::string& path = t.path;
    if (path == "/healthz") {
      require_method(req, {http::verb::get, http::verb::head});
      return json_response(state, req, http::status::ok,
                           {{"status", state.stopping ? "stopping" : "ok"},
                            {"uptime", state.uptime()},
                            {"version", FACECAST_VERSION}});
    }
    if (path == "/readyz") {
      require_method(req, {http::verb::get, http::verb::head});
      const bool ready = state.ready && !state.stopping;
      return json_response(state, req, ready ? http::status::ok : http::status::service_unavailable,
                           {{"status", ready            ? "ready"
                                       : state.stopping ? "draining"
                                                        : "starting"}});
    }
    if (path == "/metrics") {
      require_method(req, {http::verb::get, http::verb::head});
      http::response<http::string_body> res{http::status::ok, req.version()};
      res.set(http::field::content_type, "text/plain; version=0.0.4; charset=utf-8");
      res.set(http::field::cache_control, "no-store");
      res.keep_alive(req.keep_alive());
      if (req.method() != http::verb::head) {
        res.body() = state.metrics.render();
        if (state.channels) res.body() += channel_metrics(*state.channels);
      }
      return finish(state, std::move(res));
    }
    if (path == "/ws") {
      throw RequestError(Code::kInvalidInput,
                         "/ws is a WebSocket endpoint (subprotocol facecast.v1)", 426);
    }
    if (path.starts_with("/api/channels/")) return channel_api(state, req, t);
    if (path == "/api" || path.starts_with("/api/")) {
      if (!token_ok(state, req, t))
        throw RequestError(Code::kUnauthorized,
                           "a token is required (?token= or Authorization: Bearer)");
      return api(state, req, t);
    }
    require_method(req, {http::verb::get, http::verb::head});
    if (path.starts_with("/vendor/three/"))
      return serve_file(state, req, state.three_root,
                        path.substr(std::string_view("/vendor/three/").size()));
    if (path.starts_with("/vendor/three-vrm/"))
      return serve_file(state, req, state.three_vrm_root,
                        path.substr(std::string_view("/vendor/three-vrm/").size()));
    return serve_file(state, req, state.web_root, path.substr(1));
  } catch (...) {
    const Problem p = describe(std::current_exception());
    if (p.status >= 500)
      log::error("http_error", {{"target", std::string(req.target())}, {"error", p.message}});
    auto res = error_response(state, req.version(), req.keep_alive(), p);
    return res;
  }
}

http::message_generator serve_file(State& state, const Request& req, const fs::path& root,
                                   std::string_view rel) {
  // Every segment must be a plain name: no "..", no ".", no hidden files, no backslashes.
  fs::path relative;
  std::string_view rest = rel;
  bool directory = rel.empty() || rel.back() == '/';
  while (!rest.empty()) {
    const auto slash = rest.find('/');
    const std::string_view seg = rest.substr(0, slash);
    if (!seg.empty()) {
      if (seg == ".." || seg == ".")
        throw Error("path: '..' and '.' are not allowed", ErrorCode::kInvalidInput);
      if (seg.front() == '.' || seg.find('\\') != std::string_view::npos)
        throw Error("not found: /" + std::string(rel), ErrorCode::kNotFound);
      relative /= fs::path(std::string(seg));
    }
    if (slash == std::string_view::npos) break;
    rest.remove_prefix(slash + 1);
  }
  fs::path path = root / relative;
  std::error_code ec;
  if (!directory && fs::is_directory(path, ec)) directory = true;
  if (directory) path /= "index.html";
  // Symlinks must not lead out of the root.
  const fs::path canonical_root = fs::weakly_canonical(root, ec);
  const fs::path canonical = fs::weakly_canonical(path, ec);
  if (ec || canonical_root.empty())
    throw Error("not found: /" + std::string(rel), ErrorCode::kNotFound);
  auto [r, c] = std::mismatch(canonical_root.begin(), canonical_root.end(), canonical.begin(),
                              canonical.end());
  if (r != canonical_root.end() || !fs::is_regular_file(canonical, ec))
    throw Error("not found: /" + std::string(rel), ErrorCode::kNotFound);
  return send_path(state, req, canonical, mime_type(canonical.string()), "no-cache");
}

std::string_view mime_type(std::string_view path) {
  const auto dot = path.rfind('.');
  if (dot == std::string_view::npos) return "application/octet-stream";
  const std::string_view ext = path.substr(dot + 1);
  static const std::pair<std::string_view, std::string_view> kTypes[] = {
      {"html", "text/html; charset=utf-8"},
      {"htm", "text/html; charset=utf-8"},
      {"js", "text/javascript; charset=utf-8"},
      {"mjs", "text/javascript; charset=utf-8"},
      {"css", "text/css; charset=utf-8"},
      {"json", "application/json"},
      {"map", "application/json"},
      {"txt", "text/plain; charset=utf-8"},
      {"md", "text/markdown; charset=utf-8"},
      {"svg", "image/svg+xml"},
      {"png", "image/png"},
      {"jpg", "image/jpeg"},
      {"jpeg", "image/jpeg"},
      {"gif", "image/gif"},
      {"webp", "image/webp"},
      {"ico", "image/x-icon"},
      {"wasm", "application/wasm"},
      {"glb", "model/gltf-binary"},
      {"gltf", "model/gltf+json"},
      {"bin", "application/octet-stream"},
      {"ktx2", "image/ktx2"},
      {"woff", "font/woff"},
      {"woff2", "font/woff2"},
      {"ttf", "font/ttf"},
      {"mp4", "video/mp4"},
      {"webm", "video/webm"},
      {"wav", "audio/wav"},
      {"mp3", "audio/mpeg"},
      {"obj", "text/plain; charset=utf-8"},
  };
  for (const auto& [e, type] : kTypes) {
    if (beast::iequals(e, ext)) return type;
  }
  return "application/octet-stream";
}

}  // namespace facecast::server
