#pragma once
// Request routing and responses (the HTTP API of docs/protocol.md).
#include <string>
#include <string_view>

#include "beast.hpp"
#include "state.hpp"

namespace facecast::server {

struct Target {
  std::string path;   // percent-decoded
  std::string query;  // raw
  bool valid = true;  // false: bad percent-encoding or a NUL byte
};
Target parse_target(std::string_view target);
/// The value of `key` in a query string, percent-decoded.
std::optional<std::string> query_value(std::string_view query, std::string_view key);

/// /api/channels/{c} and /api/channels/{c}/speak (channel.cpp).
http::message_generator channel_api(State& state, const Request& req, const Target& target);
/// A request target for the logs: ?token= values replaced by REDACTED.
std::string loggable_target(std::string_view target);
/// Body limit of a request (max_upload for POST /api/rigs and /api/render, else max_body).
std::size_t body_limit(const State& state, const Request& req);
/// Requests whose handling may take long or block (bodies to parse, big files, SQLite, Redis,
/// folder scans: every /api/ request): run on the worker pool.
bool is_heavy(const Request& req);

/// Answers one request. Never throws: failures become JSON errors (describe()).
http::message_generator handle_request(State& state, Request&& req);
http::message_generator json_response(State& state, const Request& req, http::status status,
                                      const nlohmann::json& body);
/// `req` (optional): the request answered, for its CORS headers.
http::message_generator error_response(State& state, unsigned version, bool keep_alive,
                                       const Problem& problem, const Request* req = nullptr);

/// Static files under `root` (rel is the decoded path below it, "" or ending in '/' means
/// index.html). Refuses traversal ("..", hidden segments, symlinks out of root).
http::message_generator serve_file(State& state, const Request& req,
                                   const std::filesystem::path& root, std::string_view rel);
/// MIME type by extension.
std::string_view mime_type(std::string_view path);

}  // namespace facecast::server
