#include "guard.hpp"

#include <boost/asio/ip/address.hpp>

#include "responses.hpp"
#include "routes.hpp"

namespace facecast::server {
namespace {

bool state_changing(http::verb v) {
  return v == http::verb::post || v == http::verb::put || v == http::verb::patch ||
         v == http::verb::delete_;
}

// "name:8080" -> "name", "[::1]:8080" -> "[::1]", "Name." -> "name".
std::string host_name(std::string_view host) {
  std::string_view name = host;
  if (name.starts_with('[')) {
    const auto close = name.find(']');
    name = close == std::string_view::npos ? name : name.substr(0, close + 1);
  } else if (const auto colon = name.rfind(':'); colon != std::string_view::npos) {
    name = name.substr(0, colon);
  }
  std::string out(name);
  for (auto& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (out.size() > 1 && out.back() == '.') out.pop_back();
  return out;
}

bool is_ip_literal(const std::string& name) {
  boost::system::error_code ec;
  if (name.size() > 2 && name.front() == '[' && name.back() == ']') {
    (void)boost::asio::ip::make_address_v6(name.substr(1, name.size() - 2), ec);
    return !ec;
  }
  (void)boost::asio::ip::make_address_v4(name, ec);
  return !ec;
}

// The media type of a Content-Type value, lower case, without parameters.
std::string media_type(std::string_view value) {
  value = value.substr(0, value.find(';'));
  while (!value.empty() && (value.back() == ' ' || value.back() == '\t')) value.remove_suffix(1);
  while (!value.empty() && (value.front() == ' ' || value.front() == '\t')) value.remove_prefix(1);
  std::string out(value);
  for (auto& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

bool type_accepted(const std::string& path, const std::string& type) {
  if (type == "application/json") return true;
  if (path == "/api/rigs")
    return type == "model/gltf-binary" || type == "model/vrm" || type == "application/octet-stream";
  if (path == "/api/audio")
    return type.starts_with("audio/") || type.starts_with("video/") || type == "application/ogg" ||
           type == "application/octet-stream";
  return false;
}

bool listed(const std::vector<std::string>& origins, std::string_view origin) {
  for (const auto& o : origins)
    if (o == "*" || beast::iequals(o, origin)) return true;
  return false;
}

}  // namespace

bool host_allowed(const ServerOptions& o, std::string_view host) {
  if (host.empty()) return true;  // not a browser (every browser sends Host)
  const std::string name = host_name(host);
  if (name == "localhost" || is_ip_literal(name)) return true;
  for (const auto& allowed : o.allowed_hosts)
    if (allowed == "*" || host_name(allowed) == name) return true;
  return false;
}

bool origin_ok(const ServerOptions& options, const Request& req) {
  if (!req.count(http::field::origin)) return true;  // not a browser
  const std::string_view origin = req[http::field::origin];
  if (listed(options.allowed_origins, origin) || listed(options.cors_origins, origin)) return true;
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

std::optional<Problem> check_request_header(const ServerOptions& options, const Request& req) {
  const std::string_view host = req[http::field::host];
  if (!host_allowed(options, host))
    return Problem{
        Code::kForbidden,
        "host '" + std::string(host.substr(0, 200)) + "' is not served here (allowed_hosts)", 421};
  if (state_changing(req.method()) && !origin_ok(options, req))
    return Problem{Code::kForbidden,
                   "origin '" + std::string(req[http::field::origin].substr(0, 200)) +
                       "' may not change anything here (allowed_origins, cors_origins)",
                   403};
  if ((req.method() == http::verb::post || req.method() == http::verb::put ||
       req.method() == http::verb::patch) &&
      req.count(http::field::content_type)) {
    const Target t = parse_target(req.target());
    const std::string type = media_type(req[http::field::content_type]);
    if (t.valid && (t.path == "/api" || t.path.starts_with("/api/")) &&
        !type_accepted(t.path, type))
      return Problem{Code::kUnsupported,
                     "Content-Type '" + type.substr(0, 100) + "' is not accepted by " + t.path +
                         " (application/json" +
                         (t.path == "/api/rigs"    ? ", model/gltf-binary, model/vrm"
                          : t.path == "/api/audio" ? ", audio/*"
                                                   : "") +
                         ")",
                     415};
  }
  return std::nullopt;
}

std::string cors_origin(const ServerOptions& o, const Request& req) {
  if (o.cors_origins.empty() || !req.count(http::field::origin)) return {};
  const std::string_view origin = req[http::field::origin];
  return listed(o.cors_origins, origin) ? std::string(origin) : std::string();
}

void add_cors(const ServerOptions& o, const Request& req, http::response_header<>& res) {
  const std::string origin = cors_origin(o, req);
  if (origin.empty()) return;
  res.set(http::field::access_control_allow_origin, origin);
  res.set(http::field::vary, "Origin");
}

http::message_generator preflight(const Responses& reply, const Request& req) {
  const std::string origin = cors_origin(reply.options(), req);
  if (origin.empty()) {
    return reply.error(
        req.version(), req.keep_alive(),
        Problem{Code::kForbidden,
                req.count(http::field::origin)
                    ? "origin '" + std::string(req[http::field::origin].substr(0, 200)) +
                          "' is not in cors_origins"
                    : std::string("OPTIONS answers CORS preflights of cors_origins only"),
                403});
  }
  http::response<http::empty_body> res{http::status::no_content, req.version()};
  res.set(http::field::server, "facecast");
  res.set(http::field::access_control_allow_origin, origin);
  res.set(http::field::vary, "Origin");
  res.set(http::field::access_control_allow_methods, "GET, HEAD, POST, PATCH, DELETE");
  res.set(http::field::access_control_allow_headers, "Authorization, Content-Type");
  res.set(http::field::access_control_max_age, "600");
  res.keep_alive(req.keep_alive());
  return reply.finish(std::move(res));
}

}  // namespace facecast::server
