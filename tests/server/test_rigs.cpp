// Rig jobs: upload -> job -> stored rig -> download -> speak with it -> listed after a restart;
// bad uploads; video render jobs.
#include <malloc.h>
#include <tiny_gltf.h>
#include <algorithm>
#include <catch2/catch.hpp>

#include <fstream>
#include <thread>

#include "build_paths.hpp"
#include "client.hpp"
#include "facecast/avatar/avatar.hpp"
#include "facecast/core/files.hpp"
#include "facecast/render/image.hpp"
#include "facecast/rig/avatar_document.hpp"
#include "facecast/rig/avatar_view.hpp"
#include "facecast/rig/rig_io.hpp"
#include "hostile_glb.hpp"
#include "test_avatar_file.hpp"
#include "test_data.hpp"

using namespace fctest;
using facecast::server::ServerOptions;

namespace {

std::string obj_text(const facecast::rig::Rig& rig, const std::string& name) {
  const auto path = facecast::test::scratch_dir() / (name + ".obj");
  facecast::rig::write_obj(path, rig);
  return facecast::read_file(path);
}

std::string base64(const std::string& bytes) {
  static const char* a = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned v = (static_cast<unsigned char>(bytes[i]) << 16) |
                       (static_cast<unsigned char>(bytes[i + 1]) << 8) |
                       static_cast<unsigned char>(bytes[i + 2]);
    out += a[v >> 18];
    out += a[(v >> 12) & 63];
    out += a[(v >> 6) & 63];
    out += a[v & 63];
  }
  if (i < bytes.size()) {
    unsigned v = static_cast<unsigned char>(bytes[i]) << 16;
    if (i + 1 < bytes.size()) v |= static_cast<unsigned char>(bytes[i + 1]) << 8;
    out += a[v >> 18];
    out += a[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? a[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

// Polls a job until it is done or failed.
nlohmann::json wait_job(unsigned short port, const std::string& job, double timeout) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout);
  double last_progress = -1;
  std::string last_stage;
  for (;;) {
    const auto r = http_request(port, http::verb::get, "/api/jobs/" + job);
    REQUIRE(r.status == 200);
    const auto j = r.json();
    if (j["state"] == "done" || j["state"] == "failed") return j;
    if (j["stage"] == last_stage) CHECK(j["progress"].get<double>() >= last_progress);
    last_stage = j["stage"];
    last_progress = j["progress"];
    REQUIRE(std::chrono::steady_clock::now() < deadline);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

nlohmann::json post_json(unsigned short port, const std::string& target, const nlohmann::json& body,
                         int expect) {
  const auto r = http_request(port, http::verb::post, target, body.dump());
  INFO(r.body);
  REQUIRE(r.status == expect);
  return r.json();
}

}  // namespace

TEST_CASE("rig upload builds a rig that downloads, streams and survives a restart",
          "[rigs][jobs]") {
  TestServer s;
  const auto variant = facecast::avatar::make_avatar(facecast::avatar::avatar_variant(7));
  const auto accepted = post_json(
      s.port(), "/api/rigs",
      {{"name", "Seven"}, {"mesh", {{"format", "obj"}, {"data", obj_text(variant, "variant7")}}}},
      202);
  const std::string job = accepted["job"];
  CHECK(accepted["url"] == "/api/jobs/" + job);
  const auto done = wait_job(s.port(), job, 900 * slowdown());
  INFO(done.dump());
  REQUIRE(done["state"] == "done");
  CHECK(done["kind"] == "rig");
  CHECK(done["progress"] == 1.0);
  const std::string id = done["result"]["rig"];
  CHECK(done["result"]["url"] == "/api/rigs/" + id + ".glb");
  CHECK(done["result"]["report"]["shapes"].size() == 52);
  CHECK(done["result"]["report"]["virtual_edges"]["count"].get<int>() > 0);

  const auto check_listed = [&] {
    const auto rigs = http_request(s.port(), http::verb::get, "/api/rigs").json()["rigs"];
    REQUIRE(rigs.size() == builtin_rig_ids().size() + 1);  // the built-in ones, then this one
    const auto& mine = rigs.back();
    CHECK(mine["id"] == id);
    CHECK(mine["name"] == "Seven");
    CHECK(mine["builtin"] == false);
    CHECK(mine["template"] == "default");
    CHECK(mine["vertices"] == variant.vertex_count());
    CHECK(mine["shapes"].get<std::vector<std::string>>() == facecast::avatar::avatar_shape_names());
    const auto glb = http_request(s.port(), http::verb::get, "/api/rigs/" + id + ".glb");
    REQUIRE(glb.status == 200);
    CHECK(glb.header("content-type") == "model/gltf-binary");
    const auto rig = facecast::rig::parse_glb(glb.body, "built");
    REQUIRE(rig.vertex_count() == variant.vertex_count());
    CHECK((rig.positions - variant.positions).cwiseAbs().maxCoeff() < 1e-4f);
    CHECK(rig.shapes.size() == 52);
    CHECK(rig.shapes[static_cast<std::size_t>(rig.find_shape("jawOpen"))].max_displacement() >
          0.1f);
  };
  check_listed();
  const auto edges =
      http_request(s.port(), http::verb::get, "/api/rigs/" + id + "/virtual_edges.json");
  CHECK(edges.status == 200);
  CHECK(edges.json()["edges"].size() > 0);

  // Stream with it.
  {
    WsClient c(s.port());
    auto ids = builtin_rig_ids();
    ids.push_back(id);
    CHECK(c.read_json(10)["rigs"] == ids);
    c.send(nlohmann::json{{"type", "speak"},
                          {"id", "mine"},
                          {"rig", id},
                          {"text", "My own face."},
                          {"audio", false}});
    const auto r = collect_stream(c, "mine");
    REQUIRE_FALSE(r.error);
    CHECK(r.start["rig"] == id);
    CHECK(r.end["frames"] == r.start["frames"]);
  }
  // Stored atomically: the rig's folder and no temporaries.
  const auto rig_dir = s.options().data / "rigs" / id;
  CHECK(std::filesystem::exists(rig_dir / "rig.glb"));
  CHECK(std::filesystem::exists(rig_dir / "meta.json"));
  for (const auto& e : std::filesystem::directory_iterator(s.options().data / "rigs"))
    CHECK(e.path().filename().string().find("tmp") == std::string::npos);

  s.restart();
  check_listed();
}

TEST_CASE("rig uploads with bad input are refused at once", "[rigs]") {
  TestServer s;
  const auto error = [&](const nlohmann::json& body, int status) {
    const auto r = http_request(s.port(), http::verb::post, "/api/rigs", body.dump());
    INFO(r.body);
    CHECK(r.status == status);
    return r.json()["error"]["message"].get<std::string>();
  };
  CHECK_THAT(error({{"name", "x"}}, 400), Catch::Contains("mesh: missing"));
  CHECK_THAT(error({{"mesh", {{"format", "stl"}, {"data", "solid"}}}}, 400),
             Catch::Contains("'stl' is not obj, glb or vrm"));
  CHECK_THAT(error({{"mesh", {{"format", "obj"}, {"data", "v 1 2\nf 1 2 3\n"}}}}, 400),
             Catch::Contains("mesh"));
  CHECK_THAT(error({{"mesh", {{"format", "glb"}, {"data", "@@@not base64@@@"}}}}, 400),
             Catch::Contains("not base64"));
  const std::string tetra =
      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
  {
    // Another topology without markers: the job looks for a face on the mesh and finds none.
    const auto r =
        http_request(s.port(), http::verb::post, "/api/rigs",
                     nlohmann::json{{"mesh", {{"format", "obj"}, {"data", tetra}}}}.dump());
    REQUIRE(r.status == 202);
    const auto failed = wait_job(s.port(), r.json()["job"], 120 * slowdown());
    CHECK(failed["state"] == "failed");
    CHECK_THAT(failed.dump(), Catch::Contains("no face found"));
  }
  CHECK_THAT(
      error({{"mesh", {{"format", "obj"}, {"data", tetra}}},
             {"markers",
              {{"index_base", 0}, {"pairs", {{{"name", "a"}, {"template", 1}, {"target", 99}}}}}}},
            400),
      Catch::Contains("99"));
  CHECK_THAT(error({{"template", "nope"}, {"mesh", {{"format", "obj"}, {"data", tetra}}}}, 404),
             Catch::Contains("rig 'nope' does not exist"));
  CHECK_THAT(
      error({{"mesh", {{"format", "obj"}, {"data", tetra}}}, {"options", {{"lambda", -1}}}}, 400),
      Catch::Contains("options.lambda"));
  CHECK_THAT(error({{"mesh", {{"format", "obj"}, {"data", tetra}}}, {"colour", "red"}}, 400),
             Catch::Contains("unknown field 'colour'"));
}

TEST_CASE("a GLB upload of the same topology is accepted and shutdown cancels its job",
          "[rigs][jobs]") {
  std::filesystem::path data;
  {
    TestServer s([](ServerOptions& o) { o.shutdown_timeout = 3; });
    data = s.options().data;
    // A GLB groups triangles by material, so their order differs from the template's.
    const auto variant = facecast::avatar::make_avatar(facecast::avatar::avatar_variant(3));
    const auto accepted = post_json(
        s.port(), "/api/rigs",
        {{"mesh", {{"format", "glb"}, {"data", base64(facecast::rig::glb_bytes(variant))}}}}, 202);
    const std::string job = accepted["job"];
    const auto j = http_request(s.port(), http::verb::get, "/api/jobs/" + job).json();
    CHECK((j["state"] == "queued" || j["state"] == "running"));
    // A second job waits behind it (one job worker); max_jobs bounds the queue.
    const auto t0 = std::chrono::steady_clock::now();
    s.server().stop();
    s.server().wait();
    CHECK(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() <
          10 * slowdown());
  }
  // Nothing half-built is left behind.
  for (const auto& e : std::filesystem::directory_iterator(data / "rigs")) FAIL(e.path().string());
}

TEST_CASE("a rig build for an avatar GLB writes its shapes into that file and keeps the rest",
          "[rigs][jobs][avatar][slow]") {
  TestServer s;
  // The built-in avatar's file without morph targets: five meshes, their materials and textures.
  // A node and a generator of the user's own that a re-export would not have.
  facecast::rig::Rig bare = facecast::avatar::default_avatar();
  bare.shapes.clear();
  auto doc = facecast::rig::AvatarDocument::parse(facecast::rig::glb_bytes(bare), "bare.glb");
  doc.model().asset.generator = "a user's tool";
  tinygltf::Node extra;
  extra.name = "CameraTarget";
  doc.model().nodes.push_back(extra);
  doc.model().scenes[0].nodes.push_back(static_cast<int>(doc.model().nodes.size()) - 1);
  const std::string glb = doc.glb_bytes();
  const auto accepted =
      post_json(s.port(), "/api/rigs",
                {{"name", "Bare"}, {"mesh", {{"format", "glb"}, {"data", base64(glb)}}}}, 202);
  const auto done = wait_job(s.port(), accepted["job"], 900 * slowdown());
  INFO(done.dump());
  REQUIRE(done["state"] == "done");
  const auto back =
      http_request(s.port(), http::verb::get, done["result"]["url"].get<std::string>());
  REQUIRE(back.status == 200);

  const auto before = facecast::rig::AvatarDocument::parse(glb, "bare.glb");
  const auto after = facecast::rig::AvatarDocument::parse(back.body, "built.glb");
  const tinygltf::Model &a = before.model(), &b = after.model();
  REQUIRE(a.meshes.size() == b.meshes.size());
  CHECK(b.asset.generator == "a user's tool");
  REQUIRE(a.nodes.size() == b.nodes.size());
  CHECK(b.nodes.back().name == "CameraTarget");
  CHECK(a.materials.size() == b.materials.size());
  REQUIRE(a.images.size() == b.images.size());
  const auto image = [](const tinygltf::Model& m, std::size_t k) {
    const auto& v = m.bufferViews[static_cast<std::size_t>(m.images[k].bufferView)];
    const auto& d = m.buffers[static_cast<std::size_t>(v.buffer)].data;
    return std::string(reinterpret_cast<const char*>(d.data() + v.byteOffset), v.byteLength);
  };
  for (std::size_t i = 0; i < a.images.size(); ++i) CHECK(image(a, i) == image(b, i));
  for (std::size_t i = 0; i < b.meshes.size(); ++i) {
    INFO(b.meshes[i].name);
    CHECK(b.meshes[i].name == a.meshes[i].name);
    CHECK(a.meshes[i].primitives[0].targets.empty());
  }
  // The new shapes live in the file's own meshes, under the template's names.
  const auto view = facecast::rig::make_view(after);
  CHECK(view.rig.vertex_count() == bare.vertex_count());
  const int jaw = view.rig.find_shape("jawOpen");
  REQUIRE(jaw >= 0);
  CHECK(view.rig.shapes[static_cast<std::size_t>(jaw)].max_displacement() > 0.1f);
  CHECK(view.rig.shapes.size() == facecast::avatar::avatar_shape_names().size());
}

TEST_CASE("render jobs produce an MP4 video", "[jobs][render]") {
  TestServer s;
  const auto accepted =
      post_json(s.port(), "/api/render",
                {{"text", "Hello."}, {"size", {160, 120}}, {"fps", 10}, {"audio", true}}, 202);
  const auto done = wait_job(s.port(), accepted["job"], 120 * slowdown());
  INFO(done.dump());
  REQUIRE(done["state"] == "done");
  CHECK(done["kind"] == "render");
  CHECK(done["result"]["audio"] == true);
  CHECK(done["result"]["frames"].get<int>() >= 5);
  const auto video = http_request(s.port(), http::verb::get, done["result"]["url"]);
  REQUIRE(video.status == 200);
  CHECK(video.header("content-type") == "video/mp4");
  REQUIRE(video.body.size() > 1000);
  CHECK(video.body.substr(4, 4) == "ftyp");
  // Errors of the request itself come back at once.
  auto r =
      http_request(s.port(), http::verb::post, "/api/render", R"({"text":"hi","size":[161,120]})");
  CHECK(r.status == 400);
  CHECK_THAT(r.body, Catch::Contains("even"));
  r = http_request(s.port(), http::verb::post, "/api/render", R"({"size":[160,120]})");
  CHECK(r.status == 400);
  CHECK_THAT(r.body, Catch::Contains("text: missing"));
}

TEST_CASE("an avatar GLB is imported as it is, served back unchanged and speaks by its own names",
          "[rigs][import]") {
  TestServer s;
  const std::string glb = facecast::test::test_avatar_glb();
  const auto r = http_request(s.port(), http::verb::post, "/api/rigs?name=My%20avatar", glb,
                              {{"Content-Type", "model/gltf-binary"}});
  INFO(r.body);
  REQUIRE(r.status == 201);
  const auto info = r.json();
  const std::string id = info["id"];
  CHECK(info["name"] == "My avatar");
  CHECK(info["imported"] == true);
  CHECK(info["url"] == "/api/rigs/" + id + ".glb");
  const auto names = info["shapes"].get<std::vector<std::string>>();
  REQUIRE(std::find(names.begin(), names.end(), "jawOpen") != names.end());
  // Byte for byte.
  const auto back = http_request(s.port(), http::verb::get, "/api/rigs/" + id + ".glb");
  REQUIRE(back.status == 200);
  CHECK(back.body == glb);
  // Weights by the avatar's own names; frames rendered from all its meshes.
  WsClient c(s.port());
  c.read_json(10);
  c.send(nlohmann::json{
      {"type", "speak"}, {"id", "w"}, {"rig", id}, {"text", "Hello."}, {"audio", false}});
  const auto w = collect_stream(c, "w");
  REQUIRE_FALSE(w.error);
  CHECK(w.start["names"].get<std::vector<std::string>>() == names);
  CHECK_FALSE(w.weights.empty());
  c.send(nlohmann::json{{"type", "speak"},
                        {"id", "f"},
                        {"rig", id},
                        {"text", "Hello."},
                        {"output", "frames"},
                        {"size", {160, 120}},
                        {"fps", 10},
                        {"audio", false}});
  const auto f = collect_stream(c, "f");
  REQUIRE_FALSE(f.error);
  CHECK_FALSE(f.frames.empty());

  // Not an avatar: a one-line error, nothing stored.
  const auto bad = http_request(s.port(), http::verb::post, "/api/rigs", "glTF but not really",
                                {{"Content-Type", "model/gltf-binary"}});
  CHECK(bad.status == 400);
  CHECK(bad.json()["error"]["message"].get<std::string>().find('\n') == std::string::npos);
  CHECK(http_request(s.port(), http::verb::get, "/api/rigs").json()["rigs"].size() == 3);
}

TEST_CASE("a web-optimized avatar (meshopt and WebP) imports, speaks and renders like the original",
          "[rigs][import][texture]") {
  // The test avatar as web pipelines ship it: gltf-transform webp, then meshopt (a later webp
  // would decode the meshopt streams).
  const std::filesystem::path dir = facecast::test::scratch_dir() / "web-avatar";
  std::filesystem::create_directories(dir);
  facecast::write_file_atomic(dir / "base.glb", facecast::test::test_avatar_glb());
  const std::string tool =
      facecast::test::source_dir().string() + "/node_modules/.bin/gltf-transform ";
  for (const auto& [command, in, out] :
       {std::tuple{"webp", "base.glb", "webp.glb"}, {"meshopt", "webp.glb", "web.glb"}}) {
    const std::string cmd = tool + command + " '" + (dir / in).string() + "' '" +
                            (dir / out).string() + "' > '" + (dir / out).string() + ".log' 2>&1";
    INFO(cmd);
    REQUIRE(std::system(cmd.c_str()) == 0);
  }
  const std::string web = facecast::read_file(dir / "web.glb");
  REQUIRE_THAT(web,
               Catch::Contains("EXT_meshopt_compression") && Catch::Contains("EXT_texture_webp"));

  TestServer s;
  WsClient c(s.port());
  c.read_json(10);
  // The first frame of "Hello." in each: the same picture within a few levels.
  std::vector<facecast::render::Image> first;
  for (const std::string& glb : {facecast::test::test_avatar_glb(), web}) {
    const auto r = http_request(s.port(), http::verb::post, "/api/rigs?name=web", glb,
                                {{"Content-Type", "model/gltf-binary"}});
    INFO(r.body);
    REQUIRE(r.status == 201);
    c.send(nlohmann::json{{"type", "speak"},
                          {"id", "f"},
                          {"rig", r.json()["id"]},
                          {"text", "Hello."},
                          {"output", "frames"},
                          {"size", {160, 120}},
                          {"fps", 10},
                          {"audio", false}});
    const auto f = collect_stream(c, "f");
    REQUIRE_FALSE(f.error);
    REQUIRE_FALSE(f.frames.empty());
    first.push_back(facecast::render::decode_image(f.frames.front().jpeg, "frame"));
  }
  const auto d = facecast::render::compare_images(first[0], first[1], 24);
  INFO("mean " << d.mean_abs << ", over 24: " << d.fraction_over);
  CHECK(d.mean_abs < 3.0);
  CHECK(d.fraction_over < 0.02);
}

namespace {

// This process's resident memory (the server runs in it), in KiB, once the allocator has given
// back what was freed (glibc keeps freed blocks of every thread's arena otherwise).
long rss_kib() {
  malloc_trim(0);
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  return -1;
}

}  // namespace

TEST_CASE("hostile avatar uploads are refused from what they declare, in little time and memory",
          "[rigs][import][limits]") {
  TestServer s;
  const auto upload = [&](const std::string& bytes) {
    return http_request(s.port(), http::verb::post, "/api/rigs?name=Avatar", bytes,
                        {{"Content-Type", "model/gltf-binary"}});
  };
  const std::string glb = facecast::test::test_avatar_glb();
  REQUIRE(upload(glb).status == 201);  // warms the allocator and the server up...
  const auto attacks = facecast::test::hostile::glb_attacks();
  for (const auto& f : attacks) CHECK(upload(f.bytes).status == 413);  // the same warm-up
  const long before = rss_kib();
  double slowest = 0;
  for (int round = 0; round < 3; ++round) {
    for (const auto& f : attacks) {
      INFO(f.name << " (" << f.bytes.size() << " bytes), round " << round);
      const auto t0 = std::chrono::steady_clock::now();
      const auto r = upload(f.bytes);
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      slowest = std::max(slowest, seconds);
      INFO(r.body);
      CHECK(r.status == 413);
      const std::string message = r.json()["error"]["message"];
      CHECK(message.rfind("upload" + f.error, 0) == 0);
      CHECK(message.find('\n') == std::string::npos);
      CHECK(seconds < 5 * slowdown());
      CHECK(http_request(s.port(), http::verb::get, "/healthz").status == 200);
    }
  }
  const long after = rss_kib();
  INFO("RSS " << before << " -> " << after << " KiB; slowest refusal " << slowest << " s");
  // Nothing of the sizes declared (GiBs) was allocated. What remains is the HTTP layer's: 2 MiB
  // uploads of garbage leave as much behind (about 5 to 15 MiB a round here). Sanitizers keep
  // freed memory in quarantine: their RSS grows several times faster.
  CHECK(after - before < 50 * 1024 * slowdown());
  // Nothing was stored, and a normal upload still works.
  CHECK(http_request(s.port(), http::verb::get, "/api/rigs").json()["rigs"].size() ==
        builtin_rig_ids().size() + 1);
  CHECK(upload(glb).status == 201);
}

TEST_CASE("decode limits come from the server's config", "[rigs][import][limits]") {
  TestServer s([](ServerOptions& o) { o.decode.max_json_depth = 16; });
  facecast::test::hostile::Doc d = facecast::test::hostile::triangle();
  const std::string deep = facecast::test::hostile::make_glb(
      facecast::test::hostile::with_member(d, "\"extras\":" + facecast::test::hostile::nested(20)),
      d.bin);
  const auto r = http_request(s.port(), http::verb::post, "/api/rigs", deep,
                              {{"Content-Type", "model/gltf-binary"}});
  CHECK(r.status == 413);
  CHECK_THAT(r.body, Catch::Contains("upload: JSON nests deeper than 16 levels"));
}
