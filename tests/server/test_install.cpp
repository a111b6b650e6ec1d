// `cmake --install build --prefix P`, then `P/bin/facecast serve` from another folder: configs,
// web files, three.js, three-vrm, the Chinese lexicon and the shipped template come from P, found
// relative to the binary.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cstdlib>

#include "build_paths.hpp"
#include "client.hpp"
#include "facecast/avatar/avatar.hpp"
#include "facecast/core/files.hpp"
#include "facecast/rig/rig_io.hpp"
#include "serve_process.hpp"
#include "test_data.hpp"

using namespace fctest;
namespace fs = std::filesystem;

TEST_CASE("an installed facecast serves from another folder", "[install]") {
  const fs::path prefix = facecast::test::scratch_dir() / "prefix";
  const std::string install = std::string("\"") + facecast::test::cmake_command().string() +
                              "\" --install \"" + facecast::test::build_dir().string() +
                              "\" --prefix \"" + prefix.string() + "\" > \"" +
                              (prefix.string() + ".log") + "\" 2>&1";
  REQUIRE(std::system(install.c_str()) == 0);
  const fs::path share = prefix / "share/facecast";
  for (const char* f :
       {"bin/facecast", "share/facecast/configs/server.json", "share/facecast/web/index.html",
        "share/facecast/zh_lexicon.txt", "share/facecast/node_modules/three/build/three.module.js",
        "share/facecast/node_modules/@pixiv/three-vrm/lib/three-vrm.module.js",
        "share/facecast/deploy/nginx.conf", "lib/systemd/system/facecast.service"}) {
    INFO(f);
    CHECK(fs::exists(prefix / f));
  }
  // The installed config is the one read: a limit changed there shows in the answers.
  auto config = nlohmann::json::parse(facecast::read_file(share / "configs/server.json"));
  config["max_text"] = 40;
  facecast::write_file_atomic(share / "configs/server.json", config.dump(2));

  // Nothing from the source or build tree: no overrides, no Chinese sources (the lexicon must
  // come from P), and the working folder elsewhere.
  for (const char* v : {"FACECAST_CONFIG_DIR", "FACECAST_ZH_LEXICON", "FACECAST_SHARED_DATA"})
    unsetenv(v);
  setenv("FACECAST_RIME_DICT", "/nonexistent/pinyin_simp.dict.yaml", 1);
  setenv("FACECAST_UNIHAN_READINGS", "/nonexistent/Unihan_Readings.txt", 1);
  const fs::path elsewhere = facecast::test::scratch_dir() / "elsewhere";
  fs::create_directories(elsewhere);
  const fs::path old_cwd = fs::current_path();
  fs::current_path(elsewhere);
  ServeProcess serve((prefix / "bin/facecast").string(), {"--log-level", "warn"}, 60 * slowdown());
  fs::current_path(old_cwd);

  const auto health = http_request(serve.port(), http::verb::get, "/healthz");
  REQUIRE(health.status == 200);
  CHECK(health.json()["status"] == "ok");
  const auto index = http_request(serve.port(), http::verb::get, "/");
  CHECK(index.status == 200);
  CHECK(index.body == facecast::read_file(share / "web/index.html"));
  CHECK(http_request(serve.port(), http::verb::get, "/vendor/three/build/three.module.js").status ==
        200);
  CHECK(
      http_request(serve.port(), http::verb::get, "/vendor/three-vrm/three-vrm.module.js").status ==
      200);
  // The shipped template (rigbuild/data/ in the source tree), installed with its licence and
  // offered from P.
  REQUIRE(fs::exists(share / "ict_facekit.glb"));
  CHECK(fs::exists(share / "ict_facekit.LICENSE"));
  const auto shipped = http_request(serve.port(), http::verb::get, "/api/rigs/ict-facekit.glb");
  CHECK(shipped.status == 200);
  CHECK(shipped.body == facecast::read_file(share / "ict_facekit.glb"));

  WsClient c(serve.port());
  CHECK(c.read_json(20 * slowdown())["type"] == "hello");
  c.send(nlohmann::json{{"type", "speak"}, {"id", "zh"}, {"text", "你好，世界。Hello."}});
  const auto r = collect_stream(c, "zh", 60 * slowdown());
  REQUIRE_FALSE(r.error);
  CHECK(r.end["frames"].get<int>() > 10);
  CHECK_FALSE(r.audio.empty());
  c.send(nlohmann::json{{"type", "speak"}, {"id", "long"}, {"text", std::string(41, 'a')}});
  const auto refused = collect_stream(c, "long", 20 * slowdown());
  REQUIRE(refused.error);
  CHECK_THAT((*refused.error)["message"].get<std::string>(), Catch::Contains("40"));
  // Data went to the working folder's data/, not into P.
  CHECK(fs::exists(elsewhere / "data/rigs"));

  // An install that lost its shipped template: a build asks for --template in one line and writes
  // nothing.
  fs::remove(share / "ict_facekit.glb");
  const fs::path head = elsewhere / "head.obj", out = elsewhere / "me.glb";
  facecast::rig::write_obj(head, facecast::avatar::default_avatar());
  const fs::path log = elsewhere / "build.log";
  const std::string build = "\"" + (prefix / "bin/facecast").string() + "\" rig build --target \"" +
                            head.string() + "\" --out \"" + out.string() + "\" 2> \"" +
                            log.string() + "\"";
  CHECK(std::system(build.c_str()) != 0);
  const std::string said = facecast::read_file(log);
  INFO(said);
  CHECK(said.find("ict_facekit.glb: the shipped template is missing") != std::string::npos);
  CHECK(said.find("give --template") != std::string::npos);
  CHECK_FALSE(fs::exists(out));
}
