// The photo job (POST /api/photo) and the landmark preview (POST /api/photo/landmarks): bad
// requests refused at once, bad photos failing the job with a one-line error and storing nothing,
// and astronaut.png (scikit-image, public domain) built into a listed, textured, speaking rig from
// the shipped template.
#include <catch2/catch.hpp>
#include <thread>

#include "client.hpp"
#include "exif.hpp"
#include "facecast/core/files.hpp"
#include "facecast/render/image.hpp"
#include "facecast/rig/rig_io.hpp"
#include "hostile_glb.hpp"
#include "test_data.hpp"

using namespace fctest;

namespace {

std::string base64(const std::string& bytes) {
  static const char* a = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    unsigned v = static_cast<unsigned char>(bytes[i]) << 16;
    if (i + 1 < bytes.size()) v |= static_cast<unsigned char>(bytes[i + 1]) << 8;
    if (i + 2 < bytes.size()) v |= static_cast<unsigned char>(bytes[i + 2]);
    out += a[v >> 18];
    out += a[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? a[(v >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? a[v & 63] : '=';
  }
  return out;
}

// A smooth colour gradient (no face in it) as a PNG data URL.
std::string gradient_png(int width, int height) {
  facecast::render::Image img;
  img.width = width;
  img.height = height;
  img.pixels.resize(static_cast<std::size_t>(width) * height * 3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      auto* p = &img.pixels[(static_cast<std::size_t>(y) * width + x) * 3];
      p[0] = static_cast<std::uint8_t>(255 * x / width);
      p[1] = static_cast<std::uint8_t>(255 * y / height);
      p[2] = 128;
    }
  return "data:image/png;base64," + base64(facecast::render::encode_png(img));
}

nlohmann::json wait_job(unsigned short port, const std::string& job, double timeout) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout);
  for (;;) {
    const auto r = http_request(port, http::verb::get, "/api/jobs/" + job);
    REQUIRE(r.status == 200);
    const auto j = r.json();
    if (j["state"] == "done" || j["state"] == "failed") return j;
    REQUIRE(std::chrono::steady_clock::now() < deadline);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

std::size_t rig_count(unsigned short port) {
  return http_request(port, http::verb::get, "/api/rigs").json()["rigs"].size();
}

std::filesystem::path astronaut() {
  for (const char* p :
       {"/usr/lib/python3/dist-packages/skimage/data/astronaut.png",
        "/opt/facecast-testdata/python3-skimage/usr/lib/python3/dist-packages/skimage/data/"
        "astronaut.png"})
    if (std::filesystem::exists(p)) return p;
  return "/opt/facecast-testdata/python3-skimage/usr/lib/python3/dist-packages/skimage/data/"
         "astronaut.png";
}

}  // namespace

TEST_CASE("photo requests with bad input are refused at once", "[photo]") {
  TestServer s;
  const auto error = [&](const std::string& target, const nlohmann::json& body) {
    const auto r = http_request(s.port(), http::verb::post, target, body.dump());
    INFO(r.body);
    CHECK(r.status == 400);
    const std::string message = r.json()["error"]["message"].get<std::string>();
    CHECK(message.find('\n') == std::string::npos);
    return message;
  };
  CHECK_THAT(error("/api/photo", {{"name", "x"}}), Catch::Contains("front: missing"));
  CHECK_THAT(error("/api/photo", {{"front", "@@@"}}), Catch::Contains("front: not base64"));
  CHECK_THAT(error("/api/photo", {{"front", base64("not an image at all")}}),
             Catch::Contains("front"));
  CHECK_THAT(error("/api/photo", {{"front", gradient_png(64, 64)}, {"colour", "red"}}),
             Catch::Contains("unknown field 'colour'"));
  CHECK_THAT(error("/api/photo/landmarks", nlohmann::json::object()),
             Catch::Contains("photo: missing"));
  // No face: the preview says so at once.
  CHECK_THAT(error("/api/photo/landmarks", {{"photo", gradient_png(400, 300)}}),
             Catch::Contains("photo: no face found"));
  CHECK_THAT(error("/api/photo/landmarks", {{"photo", gradient_png(40, 30)}}),
             Catch::Contains("too small"));
  CHECK(rig_count(s.port()) == builtin_rig_ids().size());
}

TEST_CASE("a photo job without a face fails with one line and stores nothing", "[photo]") {
  TestServer s;
  const std::size_t before = rig_count(s.port());
  const auto rigs = s.options().data / "rigs";
  const auto entries = [&] {
    std::size_t n = 0;
    if (std::filesystem::exists(rigs))
      for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(rigs)) ++n;
    return n;
  };
  const std::size_t files_before = entries();
  for (const auto& [photo, expect] :
       {std::pair{gradient_png(400, 300), "front photo: no face found"},
        std::pair{gradient_png(40, 30), "front photo: photo too small"}}) {
    const auto r = http_request(s.port(), http::verb::post, "/api/photo",
                                nlohmann::json{{"front", photo}}.dump());
    INFO(r.body);
    REQUIRE(r.status == 202);
    const auto j = wait_job(s.port(), r.json()["job"], 120 * slowdown());
    INFO(j.dump());
    CHECK(j["state"] == "failed");
    const std::string message = j["error"].is_object() ? j["error"]["message"].get<std::string>()
                                                       : j["error"].get<std::string>();
    CHECK_THAT(message, Catch::Contains(expect));
    CHECK(message.find('\n') == std::string::npos);
  }
  CHECK(rig_count(s.port()) == before);
  CHECK(entries() == files_before);
}

TEST_CASE("astronaut.png becomes a listed, textured, speaking rig", "[photo][slow]") {
  const auto path = astronaut();
  if (!facecast::test::require_data(path) ||
      !facecast::test::require_data(facecast::test::ict_dir() / "generic_neutral_mesh.obj"))
    return;  // the shipped template is packed from the FaceKit
  TestServer s;
  const std::string photo = "data:image/png;base64," + base64(facecast::read_file(path));
  const auto lm = http_request(s.port(), http::verb::post, "/api/photo/landmarks",
                               nlohmann::json{{"photo", photo}}.dump());
  INFO(lm.body);
  REQUIRE(lm.status == 200);
  CHECK(lm.json()["points"].size() == 68);
  CHECK(lm.json()["width"] == 512);

  const auto r = http_request(s.port(), http::verb::post, "/api/photo",
                              nlohmann::json{{"front", photo}, {"name", "Astronaut"}}.dump());
  REQUIRE(r.status == 202);
  const auto j = wait_job(s.port(), r.json()["job"], 600 * slowdown());
  INFO(j.dump().substr(0, 2000));
  REQUIRE(j["state"] == "done");
  const std::string id = j["result"]["rig"];
  const auto list = http_request(s.port(), http::verb::get, "/api/rigs").json()["rigs"];
  bool listed = false;
  for (const auto& rig : list)
    if (rig["id"] == id) listed = rig["name"] == "Astronaut";
  CHECK(listed);
  const auto glb = http_request(s.port(), http::verb::get, "/api/rigs/" + id + ".glb");
  REQUIRE(glb.status == 200);
  const auto rig = facecast::rig::parse_glb(glb.body, "photo rig");
  CHECK(rig.find_shape("jawOpen") >= 0);
  CHECK(rig.find_shape("mouthSmileLeft") >= 0);
  for (const auto& name : rig.shape_names()) CHECK_FALSE(name.starts_with("identity"));
  CHECK(rig.textures.size() >= 1);

  // It speaks like any other rig.
  WsClient c(s.port());
  auto ids = builtin_rig_ids();
  ids.push_back(id);
  CHECK(c.read_json(10)["rigs"] == ids);
  c.send(nlohmann::json{
      {"type", "speak"}, {"id", "me"}, {"rig", id}, {"text", "My own face."}, {"audio", false}});
  const auto streamed = collect_stream(c, "me");
  REQUIRE_FALSE(streamed.error);
  CHECK(streamed.start["rig"] == id);
  CHECK(streamed.end["frames"] == streamed.start["frames"]);
}

TEST_CASE("a phone's portrait stored sideways is read upright", "[photo]") {
  const auto path = astronaut();
  if (!facecast::test::require_data(path)) return;
  TestServer s;
  const auto landmarks = [&](const std::string& photo) {
    const auto r = http_request(s.port(), http::verb::post, "/api/photo/landmarks",
                                nlohmann::json{{"photo", photo}}.dump());
    INFO(r.body);
    REQUIRE(r.status == 200);
    return r.json();
  };
  const auto upright = facecast::render::read_image(path);
  const auto expected = landmarks(base64(facecast::render::encode_jpeg(upright, 95)));
  // The pixels sideways, with an EXIF Orientation of 6 (turn 90 degrees clockwise to show), as a
  // phone stores a portrait.
  const auto turned = landmarks(base64(facecast::test::with_exif_orientation(
      facecast::render::encode_jpeg(facecast::render::apply_orientation(upright, 8), 95), 6)));
  CHECK(turned["width"] == 512);
  double largest = 0;
  for (std::size_t k = 0; k < 68; ++k)
    for (std::size_t c = 0; c < 2; ++c)
      largest = std::max(largest, std::abs(turned["points"][k][c].get<double>() -
                                           expected["points"][k][c].get<double>()));
  CHECK(largest < 2.0);  // the two JPEGs' blocks differ: the predictor moves by a pixel at most
}

TEST_CASE("photos are checked against the decode limits from their header", "[photo][limits]") {
  TestServer s([](facecast::server::ServerOptions& o) { o.decode.max_image_bytes = 4 << 20; });
  const auto refused = [&](const std::string& target, const nlohmann::json& body) {
    const auto r = http_request(s.port(), http::verb::post, target, body.dump());
    INFO(r.body);
    CHECK(r.status == 413);
    return r.json()["error"]["message"].get<std::string>();
  };
  const std::string huge = base64(facecast::test::hostile::png_header(100000, 100000));
  CHECK(refused("/api/photo/landmarks", {{"photo", huge}}) ==
        "photo: png image of 100000x100000 is over the limit of 8192 pixels a side "
        "(max_image_side)");
  CHECK(refused("/api/photo", {{"front", "data:image/png;base64," + huge}}) ==
        "front: png image of 100000x100000 is over the limit of 8192 pixels a side "
        "(max_image_side)");
  // Within the side, over the server's max_image_bytes (4 MiB here).
  CHECK(refused("/api/photo/landmarks", {{"photo", gradient_png(1100, 1000)}}) ==
        "photo: png image of 1100x1000 decodes to 4400000 bytes, over the limit of 4194304 "
        "(max_image_bytes)");
  CHECK(rig_count(s.port()) == builtin_rig_ids().size());
}
