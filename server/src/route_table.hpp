#pragma once
// The HTTP API as data: every operation the server answers (routes.cpp and channel.cpp dispatch
// them) with the scope it needs, and the OpenAPI 3.1 document of docs/openapi.json (compiled in,
// served at GET /api/openapi.json). tests/server/test_openapi.cpp keeps the table, the dispatcher
// and the document in step: each route is answered, each is documented, nothing else is.
#include <span>
#include <string_view>

namespace facecast::server {

struct Route {
  std::string_view method;  // "GET", "POST", "PATCH", "DELETE" (GET routes answer HEAD too)
  std::string_view path;    // OpenAPI template: /api/rigs/{id}
  std::string_view scope;   // what a key needs ("" when the route is public)
};

std::span<const Route> http_routes();

/// docs/openapi.json as built.
std::string_view openapi_document();

}  // namespace facecast::server
