// The HTTP API's three descriptions agree: the server's route table (server/src/route_table.hpp),
// what the dispatcher answers, and the OpenAPI document it serves (docs/openapi.json, validated
// against the OpenAPI 3.1 schema by tests/server/openapi_validate.mjs).
#include <catch2/catch.hpp>
#include <regex>
#include <set>

#include "build_paths.hpp"
#include "client.hpp"
#include "facecast/core/files.hpp"
#include "route_table.hpp"

using namespace fctest;
namespace server = facecast::server;

namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

http::verb verb_of(std::string_view method) {
  if (method == "GET") return http::verb::get;
  if (method == "POST") return http::verb::post;
  if (method == "PATCH") return http::verb::patch;
  if (method == "DELETE") return http::verb::delete_;
  FAIL("method " << method);
  return http::verb::unknown;
}

}  // namespace

TEST_CASE("every route is answered and documented, and the document has nothing else",
          "[http][openapi]") {
  TestServer s([](server::ServerOptions& o) {
    o.channels.push_back({"show", "producer-secret-1", "default", {}});
    o.channel_idle = 0;
  });
  const auto served = http_request(s.port(), http::verb::get, "/api/openapi.json");
  REQUIRE(served.status == 200);
  CHECK(served.header("content-type") == "application/json");
  const nlohmann::json doc = served.json();
  CHECK(doc["openapi"] == "3.1.0");
  CHECK(served.body ==
        facecast::read_file(facecast::test::source_dir().string() + "/docs/openapi.json"));

  std::set<std::pair<std::string, std::string>> table, documented;
  for (const server::Route& r : server::http_routes()) {
    INFO(r.method << " " << r.path);
    table.emplace(lower(r.method), std::string(r.path));
    // Documented, with its path parameters declared and its scope (or none: public).
    const auto& op = doc["paths"][std::string(r.path)][lower(r.method)];
    REQUIRE(op.is_object());
    std::set<std::string> declared;
    for (const auto& p : op.value("parameters", nlohmann::json::array()))
      if (p["in"] == "path") declared.insert(p["name"].get<std::string>());
    std::set<std::string> in_path;
    const std::string path(r.path);
    const std::regex param("\\{([a-z]+)\\}");
    for (auto it = std::sregex_iterator(path.begin(), path.end(), param);
         it != std::sregex_iterator(); ++it)
      in_path.insert((*it)[1]);
    CHECK(declared == in_path);
    if (r.scope.empty()) {
      CHECK(op["security"] == nlohmann::json::array());
    } else {
      CHECK(op["x-facecast-scope"] == r.scope);
    }
    // Answered -- 400 for an empty body, 404 for a rig that does not exist... -- with a status the
    // document lists for it, not "no such endpoint" and not "method not allowed".
    const std::string target =
        std::regex_replace(std::regex_replace(path, std::regex("\\{c\\}"), "show"),
                           std::regex("\\{id\\}"), path.starts_with("/api/jobs/") ? "j0" : "nope");
    const auto res = http_request(s.port(), verb_of(r.method), target);
    INFO(target << ": " << res.status << " " << res.body);
    CHECK(res.status != 405);
    CHECK(res.body.find("no API endpoint") == std::string::npos);
    CHECK(res.body.find("not found: ") == std::string::npos);
    CHECK(op["responses"].contains(std::to_string(res.status)));
  }
  for (const auto& [path, item] : doc["paths"].items())
    for (const auto& [method, op] : item.items()) documented.emplace(method, path);
  CHECK(documented == table);
  // A method the table does not list for a path it lists is refused.
  CHECK(http_request(s.port(), http::verb::put, "/api/rigs").status == 405);
  CHECK(http_request(s.port(), http::verb::post, "/api/openapi.json").status == 405);
}
