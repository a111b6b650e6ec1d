#pragma once
// Request routing and responses (the HTTP API of docs/protocol.md).
#include <string>
#include <string_view>

#include "beast.hpp"
#include "responses.hpp"

namespace facecast::server {

struct Services;

struct Target {
  std::string path;   // percent-decoded
  std::string query;  // raw
  bool valid = true;  // false: bad percent-encoding or a NUL byte
};
Target parse_target(std::string_view target);
/// The value of `key` in a query string, percent-decoded.
std::optional<std::string> query_value(std::string_view query, std::string_view key);

/// /api/channels/{c} and /api/channels/{c}/speak (channel.cpp).
http::message_generator channel_api(Services& services, const Request& req, const Target& target);
/// A request target for the logs: ?token= values replaced by REDACTED.
std::string loggable_target(std::string_view target);
/// Body limit of a request (max_upload for POST /api/rigs and /api/render, else max_body).
std::size_t body_limit(const ServerOptions& options, const Request& req);
/// Requests whose handling may take long or block (bodies to parse, big files, SQLite, Redis,
/// folder scans: every /api/ request): run on the worker pool.
bool is_heavy(const Request& req);

/// Answers one request. Never throws: failures become JSON errors (describe()).
http::message_generator handle_request(Services& services, Request&& req);
/// Static files under `root` (rel is the decoded path below it, "" or ending in '/' means
/// index.html). Refuses traversal ("..", hidden segments, symlinks out of root).
http::message_generator serve_file(const Responses& reply, const Request& req,
                                   const std::filesystem::path& root, std::string_view rel);
/// MIME type by extension.
std::string_view mime_type(std::string_view path);

}  // namespace facecast::server
