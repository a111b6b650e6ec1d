#include "routes.hpp"

#include <ctime>
#include <regex>

#include "access.hpp"
#include "api.hpp"
#include "audio_uploads.hpp"
#include "channel.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/subprocess.hpp"
#include "guard.hpp"
#include "log.hpp"
#include "route_table.hpp"
#include "services.hpp"

namespace facecast::server {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// How the avatars stand (ServerOptions::pose), for the browser to stand them the same way: the
// kind, and a pose file's bones as rotations (quaternions x, y, z, w in the figure's axes); the
// file's path stays on the server.
json pose_json(const rig::Pose& pose) {
  using Kind = rig::Pose::Kind;
  json out = {{"kind", pose.kind == Kind::kBind   ? "bind"
                       : pose.kind == Kind::kFile ? "file"
                                                  : "rest"}};
  if (pose.kind != Kind::kFile) return out;
  json bones = json::array();
  for (const auto& b : pose.bones) {
    const auto& q = b.rotation.coeffs();  // x, y, z, w
    bones.push_back({{"bone", b.bone}, {"rotation", {q.x(), q.y(), q.z(), q.w()}}});
  }
  out["bones"] = std::move(bones);
  return out;
}

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

namespace {

// A file on disk with ETag / Last-Modified and conditional GET.
http::message_generator send_path(const Responses& reply, const Request& req, const fs::path& path,
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
    add_cors(reply.options(), req, res);
  };
  if (not_modified) {
    http::response<http::empty_body> res{http::status::not_modified, req.version()};
    headers(res);
    reply.count(304);
    res.set(http::field::server, "facecast");
    return http::message_generator(std::move(res));
  }
  if (req.method() == http::verb::head) {
    http::response<http::empty_body> res{http::status::ok, req.version()};
    headers(res);
    res.set(http::field::content_type, content_type);
    res.content_length(size);
    reply.count(200);
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
  return reply.finish(std::move(res));
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

// The built-in avatar's GLB, made in memory.
http::message_generator send_builtin_glb(Services& services, const Request& req) {
  const auto bytes = services.rigs.builtin_glb();
  const std::string etag = "\"default-" FACECAST_VERSION "-" + std::to_string(bytes->size()) + "\"";
  if (req[http::field::if_none_match] == etag) {
    http::response<http::empty_body> res{http::status::not_modified, req.version()};
    res.set(http::field::etag, etag);
    res.keep_alive(req.keep_alive());
    add_cors(services.options, req, res);
    services.responses.count(304);
    return http::message_generator(std::move(res));
  }
  http::response<http::string_body> res{http::status::ok, req.version()};
  res.set(http::field::content_type, "model/gltf-binary");
  res.set(http::field::etag, etag);
  res.set(http::field::cache_control, "no-cache");
  res.keep_alive(req.keep_alive());
  add_cors(services.options, req, res);
  if (req.method() == http::verb::head) {
    res.content_length(bytes->size());
    services.responses.count(200);
    return http::message_generator(std::move(res));
  }
  res.body() = *bytes;
  return services.responses.finish(std::move(res));
}

// A rig's GLB or virtual edges: without a key when the rig is public (built-in rigs are), so that
// viewers' browsers can load it; else rigs:read and a rig the caller may use.
RigInfo readable_rig(Services& services, const Request& req, const Target& t,
                     const std::string& id) {
  const auto info = services.rigs.find(id);
  if (info && info->is_public) return *info;
  const Principal who = services.auth.identify(req, t);
  who.require(kScopeRigsRead, "GET " + t.path);
  if (!info || !rig_usable(who, *info))
    throw Error("rig '" + id + "' does not exist", ErrorCode::kNotFound);
  return *info;
}

// A stored rig the caller may change (its tenant's; admins: any); 404 otherwise.
void check_rig_owned(Services& services, const Principal& who, const std::string& id) {
  const auto info = services.rigs.find(id);
  if (!info || (!info->builtin && !who.owns(info->tenant)))
    throw Error("rig '" + id + "' does not exist", ErrorCode::kNotFound);
}

// A job the caller may see: its tenant's (admins: any; else 404), with the scope of its kind
// (render jobs: render; rig builds, landmarks, photos: rigs:write).
void check_job(Services& services, const Principal& who, const std::string& id) {
  const auto kt = services.jobs.kind_and_tenant(id);
  if (!kt || !who.owns(kt->second))
    throw Error("job '" + id + "' does not exist", ErrorCode::kNotFound);
  who.require(kt->first == "render" ? kScopeRender : kScopeRigsWrite, kt->first + " jobs");
}

// Every /api path but /api/channels (channel.cpp): the caller is identified first (401), then
// each route asks for its scope (403) and sees only its tenant's things (404).
http::message_generator api(Services& services, Request& req, const Target& t) {
  std::smatch m;
  const std::string& path = t.path;
  if (std::regex_match(path, m, kRigGlb)) {
    require_method(req, {http::verb::get, http::verb::head});
    const RigInfo info = readable_rig(services, req, t, m[1]);
    if (!info.builtin || !services.rigs.glb_path(info.id).empty())
      return send_path(services.responses, req, services.rigs.glb_path(info.id),
                       "model/gltf-binary", "no-cache");
    return send_builtin_glb(services, req);
  }
  if (std::regex_match(path, m, kRigEdges)) {
    require_method(req, {http::verb::get, http::verb::head});
    const RigInfo info = readable_rig(services, req, t, m[1]);
    if (!info.virtual_edges)
      throw Error("rig '" + info.id + "' has no virtual edges", ErrorCode::kNotFound);
    return send_path(services.responses, req, services.rigs.virtual_edges_path(info.id),
                     "application/json", "no-cache");
  }
  const Principal who = services.auth.identify(req, t);
  if (who.viewer)
    throw RequestError(Code::kForbidden,
                       "a viewer token cannot call " + path + " (it subscribes or speaks on /ws)");
  if (path == "/api/rigs") {
    if (req.method() == http::verb::post) {
      who.require(kScopeRigsWrite, "POST /api/rigs");
      return services.rig_api.post_rig(req, t, who);
    }
    require_method(req, {http::verb::get, http::verb::head, http::verb::post});
    who.require(kScopeRigsRead, "GET /api/rigs");
    json rigs = json::array();
    for (const auto& r : services.rigs.list())
      if (rig_listed(who, r)) rigs.push_back(r.to_json());
    return services.responses.json(req, http::status::ok,
                                   {{"rigs", rigs},
                                    {"default", services.options.default_rig},
                                    {"pose", pose_json(services.options.pose)}});
  }
  if (path == "/api/tokens") {
    require_method(req, {http::verb::post});
    return services.access.post_token(req, who);
  }
  if (path == "/api/photo") {
    require_method(req, {http::verb::post});
    who.require(kScopeRigsWrite, "POST /api/photo");
    return services.rig_api.post_photo(req, who.tenant);
  }
  if (path == "/api/photo/landmarks") {
    require_method(req, {http::verb::post});
    who.require(kScopeRigsWrite, "POST /api/photo/landmarks");
    return services.rig_api.post_photo_landmarks(req);
  }
  if (path == "/api/landmarks") {
    require_method(req, {http::verb::post});
    who.require(kScopeRigsWrite, "POST /api/landmarks");
    return services.rig_api.post_landmarks(req, who);
  }
  if (path == "/api/render") {
    require_method(req, {http::verb::post});
    who.require(kScopeRender, "POST /api/render");
    return services.rig_api.post_render(req, who);
  }
  if (path == "/api/audio") {
    require_method(req, {http::verb::post});
    who.require(kScopeSpeak, "POST /api/audio");
    return post_audio(services.responses, services.jobs, services.speech.uploads(), req,
                      who.tenant);
  }
  if (std::regex_match(path, m, kJob)) {
    require_method(req, {http::verb::get, http::verb::head, http::verb::delete_});
    check_job(services, who, m[1]);
    if (req.method() == http::verb::delete_)
      return delete_job(services.responses, services.jobs, req, m[1]);
    const auto job = services.jobs.get(m[1]);
    if (!job) throw Error("job '" + std::string(m[1]) + "' does not exist", ErrorCode::kNotFound);
    return services.responses.json(req, http::status::ok, *job);
  }
  if (std::regex_match(path, m, kRig) && !path.ends_with(".glb")) {
    require_method(req, {http::verb::delete_, http::verb::patch});
    who.require(kScopeRigsWrite, std::string(req.method_string()) + " /api/rigs/{id}");
    check_rig_owned(services, who, m[1]);
    if (req.method() == http::verb::patch) return services.rig_api.patch_rig(req, m[1]);
    return services.rig_api.delete_rig(req, m[1]);
  }
  if (std::regex_match(path, m, kJobFile)) {
    require_method(req, {http::verb::get, http::verb::head});
    check_job(services, who, m[1]);
    const auto file = services.jobs.file(m[1], m[2]);
    if (!file)
      throw Error("job '" + std::string(m[1]) + "' has no " + std::string(m[2]) + " (yet)",
                  ErrorCode::kNotFound);
    return send_path(services.responses, req, *file, mime_type(m[2].str()), "no-cache");
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

std::string loggable_target(std::string_view target) {
  std::string out(target);
  const auto q = out.find('?');
  if (q == std::string::npos) return out;
  // ?token=... (and &token=...) values are credentials: never in a log line.
  for (auto at = out.find("token=", q); at != std::string::npos; at = out.find("token=", at)) {
    const bool starts = out[at - 1] == '?' || out[at - 1] == '&';
    at += 6;
    if (!starts) continue;
    const auto end = out.find('&', at);
    out.replace(at, (end == std::string::npos ? out.size() : end) - at, "REDACTED");
  }
  return out;
}

std::size_t body_limit(const ServerOptions& options, const Request& req) {
  if (req.method() == http::verb::post) {
    const auto t = parse_target(req.target());
    if (t.path == "/api/rigs" || t.path == "/api/render" || t.path == "/api/audio" ||
        t.path == "/api/photo" || t.path == "/api/photo/landmarks")
      return options.max_upload;
  }
  return options.max_body;
}

bool is_heavy(const Request& req) {
  if (req.method() == http::verb::post || req.method() == http::verb::delete_) return true;
  // Every API answer may touch SQLite, Redis or the rig folders: never on the I/O threads.
  return req.target().starts_with("/api/") || req.target() == "/api" ||
         req.target().starts_with("/api?");
}

http::message_generator handle_request(Services& services, Request&& req) {
  try {
    const Target t = parse_target(req.target());
    if (!t.valid) throw Error("bad request target");
    const std::string& path = t.path;
    if (req.method() == http::verb::options)
      return preflight(services.responses, req);  // CORS (guard.hpp)
    if (path == "/healthz") {
      require_method(req, {http::verb::get, http::verb::head});
      return services.responses.json(req, http::status::ok,
                                     {{"status", services.sessions.stopping ? "stopping" : "ok"},
                                      {"uptime", services.sessions.uptime()},
                                      {"version", FACECAST_VERSION}});
    }
    if (path == "/readyz") {
      require_method(req, {http::verb::get, http::verb::head});
      const bool ready = services.sessions.ready && !services.sessions.stopping;
      return services.responses.json(req,
                                     ready ? http::status::ok : http::status::service_unavailable,
                                     {{"status", ready                        ? "ready"
                                                 : services.sessions.stopping ? "draining"
                                                                              : "starting"}});
    }
    if (path == "/metrics") {
      require_method(req, {http::verb::get, http::verb::head});
      // With keys: a key with the metrics (or admin) scope, e.g. Prometheus' bearer credentials.
      services.auth.identify(req, t).require(kScopeMetrics, "GET /metrics");
      http::response<http::string_body> res{http::status::ok, req.version()};
      res.set(http::field::content_type, "text/plain; version=0.0.4; charset=utf-8");
      res.set(http::field::cache_control, "no-store");
      res.keep_alive(req.keep_alive());
      if (req.method() != http::verb::head) {
        res.body() = services.metrics.render();
        if (services.channels) res.body() += channel_metrics(*services.channels);
      }
      return services.responses.finish(std::move(res));
    }
    if (path == "/ws") {
      throw RequestError(Code::kInvalidInput,
                         "/ws is a WebSocket endpoint (subprotocol facecast.v1)", 426);
    }
    if (path == "/api/openapi.json") {  // public: it describes the API, it holds nothing
      require_method(req, {http::verb::get, http::verb::head});
      http::response<http::string_body> res{http::status::ok, req.version()};
      res.set(http::field::content_type, "application/json");
      res.set(http::field::cache_control, "no-cache");
      res.keep_alive(req.keep_alive());
      add_cors(services.options, req, res);
      if (req.method() != http::verb::head) res.body() = openapi_document();
      return services.responses.finish(std::move(res));
    }
    if (path.starts_with("/api/channels/")) return channel_api(services, req, t);
    if (path == "/api" || path.starts_with("/api/")) return api(services, req, t);
    require_method(req, {http::verb::get, http::verb::head});
    if (path.starts_with("/vendor/three/"))
      return serve_file(services.responses, req, services.web.three,
                        path.substr(std::string_view("/vendor/three/").size()));
    if (path.starts_with("/vendor/facecast/"))
      return serve_file(services.responses, req, services.web.client,
                        path.substr(std::string_view("/vendor/facecast/").size()));
    if (path.starts_with("/vendor/three-vrm/"))
      return serve_file(services.responses, req, services.web.three_vrm,
                        path.substr(std::string_view("/vendor/three-vrm/").size()));
    return serve_file(services.responses, req, services.web.web, path.substr(1));
  } catch (...) {
    const Problem p = describe(std::current_exception());
    if (p.status >= 500)
      log::error("http_error", {{"target", loggable_target(req.target())}, {"error", p.message}});
    auto res = services.responses.error(req.version(), req.keep_alive(), p, &req);
    return res;
  }
}

http::message_generator serve_file(const Responses& reply, const Request& req, const fs::path& root,
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
  return send_path(reply, req, canonical, mime_type(canonical.string()), "no-cache");
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
