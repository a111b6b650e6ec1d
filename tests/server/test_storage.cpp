// What tenants keep on disk (server/src/storage.hpp): a tenant over its tenant_disk_quota cannot
// store more (413 naming the quota) while another tenant can; deleting makes room; stored rigs
// older than rig_retention are removed at start, the built-in ones never.
#include <catch2/catch.hpp>
#include <thread>

#include "client.hpp"
#include "facecast/core/files.hpp"
#include "facecast/server/keys.hpp"
#include "test_avatar_file.hpp"
#include "test_data.hpp"

using namespace fctest;
namespace fs = std::filesystem;
using facecast::server::KeyStore;
using facecast::server::ServerOptions;

namespace {

Headers glb_upload(const std::string& key) {
  return with(bearer(key), "Content-Type", "model/gltf-binary");
}

bool listed(unsigned short port, const std::string& key, const std::string& rig) {
  const auto r = http_request(port, http::verb::get, "/api/rigs", {}, bearer(key));
  REQUIRE(r.status == 200);
  const nlohmann::json body = r.json();
  for (const auto& x : body["rigs"])
    if (x["id"] == rig) return true;
  return false;
}

}  // namespace

TEST_CASE("a tenant's disk quota bounds what it stores, and old rigs expire", "[rigs][quota]") {
  const fs::path data = facecast::test::scratch_dir() / "quota";
  fs::remove_all(data);
  fs::create_directories(data);
  std::string a, b;
  {
    KeyStore store(data / "keys.sqlite3", true);
    const auto scopes = facecast::server::parse_scopes("rigs:read,rigs:write,render");
    a = store.create("acme", scopes).key;
    b = store.create("globex", scopes).key;
  }
  const std::string glb = facecast::test::test_avatar_glb();
  std::string kept, fresh;
  {
    TestServer s([&](ServerOptions& o) {
      o.data = data;
      o.tenant_disk_quota = glb.size() * 3 / 2;  // room for one avatar, not two
    });
    const auto port = s.port();

    const auto first = http_request(port, http::verb::post, "/api/rigs", glb, glb_upload(a));
    REQUIRE(first.status == 201);
    const std::string rig = first.json()["id"];
    // A second one would pass the quota: refused, naming it; nothing stored.
    const auto second = http_request(port, http::verb::post, "/api/rigs", glb, glb_upload(a));
    CHECK(second.status == 413);
    CHECK_THAT(second.body,
               Catch::Contains("tenant 'acme' stores") && Catch::Contains("(tenant_disk_quota)"));
    // A render is taken while the tenant is under its quota (it is checked before the job runs).
    const auto render =
        http_request(port, http::verb::post, "/api/render", R"({"text": "Hi."})", bearer(a));
    CHECK(render.status == 202);  // under the quota: one avatar stored
    // Another tenant has its own quota.
    const auto theirs = http_request(port, http::verb::post, "/api/rigs", glb, glb_upload(b));
    REQUIRE(theirs.status == 201);
    fresh = theirs.json()["id"];
    // Deleting makes room again.
    CHECK(http_request(port, http::verb::delete_, "/api/rigs/" + rig, {}, bearer(a)).status == 200);
    const auto again = http_request(port, http::verb::post, "/api/rigs", glb, glb_upload(a));
    REQUIRE(again.status == 201);
    kept = again.json()["id"];

    // A rig stored an hour ago, with rig_retention a minute: gone after a restart; a new one and
    // the built-in ones stay.
    const fs::path meta = data / "rigs" / kept / "meta.json";
    auto m = nlohmann::json::parse(facecast::read_file(meta));
    m["created"] = m["created"].get<double>() - 3600;
    facecast::write_file_atomic(meta, m.dump());
  }
  TestServer later([&](ServerOptions& o) {
    o.data = data;
    o.rig_retention = 60;
  });
  bool gone = false;
  for (int i = 0; i < 100 && !gone; ++i) {
    gone = !listed(later.port(), a, kept);
    if (!gone) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  CHECK(gone);
  CHECK_FALSE(fs::exists(data / "rigs" / kept));
  CHECK(listed(later.port(), b, fresh));
  CHECK(listed(later.port(), a, "default"));
}
