#pragma once
// The browser as attacker (docs/security.md): checks on a request's header, made
// before its body is read or any credential is looked at.
//  - Host (every request, the WebSocket upgrade too) must be one this server answers to: the
//    loopback names localhost, 127.0.0.1, [::1], any IP address, and `allowed_hosts`, with any
//    port. A page of a rebound DNS name (evil.example resolving to 127.0.0.1) gets 421.
//  - Origin, when a browser sends one, of a WebSocket upgrade and of every POST/PUT/PATCH/DELETE:
//    the server's own origin (scheme://Host), `allowed_origins` or `cors_origins`; else 403.
//  - Content-Type of a body sent to /api: application/json, or the file types an upload endpoint
//    takes (POST /api/rigs: model/gltf-binary, model/vrm, application/octet-stream; POST
//    /api/audio: audio/*, video/*, application/ogg, application/octet-stream); anything else, as
//    the text/plain or form bodies a cross-site form or "simple" fetch can send, gets 415. A body
//    without Content-Type is read as JSON (curl -d sends a form type: use -H).
//  - CORS is off unless `cors_origins` lists origins: their preflights (OPTIONS) are answered and
//    their answers carry Access-Control-Allow-Origin; other origins' preflights get 403 and no
//    CORS header.
#include <optional>
#include <string>
#include <string_view>

#include "beast.hpp"
#include "facecast/server/protocol.hpp"

namespace facecast::server {

class Responses;

/// The Host, Origin and Content-Type checks of a request header: the problem, or nullopt.
std::optional<Problem> check_request_header(const ServerOptions& options, const Request& req);
/// Whether a Host header value ("name", "name:port", "[::1]:port") is one this server answers to.
bool host_allowed(const ServerOptions& options, std::string_view host);
/// True when a browser Origin may open a WebSocket or change state (no Origin: not a browser).
bool origin_ok(const ServerOptions& options, const Request& req);
/// The Origin of `req` when cors_origins lists it, else "".
std::string cors_origin(const ServerOptions& options, const Request& req);
/// Access-Control-Allow-Origin (and Vary: Origin) on an answer to a listed origin.
void add_cors(const ServerOptions& options, const Request& req, http::response_header<>& response);
/// OPTIONS: 204 with the CORS headers for a listed origin, 403 without them otherwise.
http::message_generator preflight(const Responses& reply, const Request& req);

}  // namespace facecast::server
