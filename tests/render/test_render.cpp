// Headless rendering on Mesa: golden images (with a tolerance) of the default avatar and the ICT
// FaceKit, GPU blending against CPU blending, threads, image files, photos' EXIF orientation and
// focal length. FACECAST_UPDATE_GOLDEN=1 rewrites the golden PNGs in tests/render/golden/.
#include <algorithm>
#include <array>
#include <catch2/catch.hpp>
#include <cstdlib>
#include <iostream>
#include <thread>

#include "build_paths.hpp"
#include "exif.hpp"
#include "facecast/avatar/avatar.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/render/renderer.hpp"
#include "facecast/rig/blend.hpp"
#include "facecast/rig/rig_io.hpp"
#include "test_data.hpp"

using namespace facecast;
using namespace facecast::render;

namespace {

RenderOptions small() {
  RenderOptions o;
  o.width = 256;
  o.height = 256;
  o.msaa = 4;  // the golden images are multisampled, with trilinear texture filtering
  o.trilinear = true;
  o.lod_pixels = 0;  // the golden images are of the full mesh (the level of detail: its own test)
  return o;
}

void check_golden(const Image& img, const std::string& name) {
  const std::filesystem::path golden =
      facecast::test::source_dir() / "tests/render/golden" / (name + ".png");
  const char* update = std::getenv("FACECAST_UPDATE_GOLDEN");
  if (update && std::string(update) == "1") {
    write_image(golden, img);
    WARN("updated " << golden.string());
    return;
  }
  write_image(test::scratch_dir() / (name + ".png"), img);
  REQUIRE(std::filesystem::exists(golden));
  const ImageDifference d = compare_images(img, read_image(golden));
  INFO(name << ": mean " << d.mean_abs << ", over threshold " << d.fraction_over << ", max "
            << d.max_abs);
  CHECK(d.mean_abs < 1.5);
  CHECK(d.fraction_over < 0.01);
}

// Fraction of pixels that differ from the background colour.
double coverage(const Image& img, const RenderOptions& o) {
  std::size_t n = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      if (std::abs(img.at(x, y, 0) - o.background.x() * 255.0f) > 8) ++n;
  return static_cast<double>(n) / (img.width * img.height);
}

}  // namespace

TEST_CASE("golden images of the default avatar", "[render]") {
  const rig::Rig& rig = avatar::default_avatar();
  const Renderer r(rig, small());
  const Image neutral = r.render(weights_for(rig, {}));
  CHECK(coverage(neutral, r.options()) > 0.3);
  check_golden(neutral, "avatar_neutral");
  check_golden(r.render(weights_for(rig, {{"jawOpen", 1.0f}})), "avatar_jaw_open");
  check_golden(r.render(weights_for(rig, {{"mouthSmileLeft", 1.0f}, {"mouthSmileRight", 1.0f}})),
               "avatar_smile");
  check_golden(r.render(weights_for(rig, {{"eyeBlinkLeft", 1.0f}, {"eyeBlinkRight", 1.0f}})),
               "avatar_blink");
  // A pose changes the picture where it should and not elsewhere.
  const Image open = r.render(weights_for(rig, {{"jawOpen", 1.0f}}));
  const ImageDifference d = compare_images(neutral, open);
  CHECK(d.fraction_over > 0.01);
  CHECK(d.fraction_over < 0.25);
}

TEST_CASE("golden images of the ICT FaceKit", "[render]") {
  const auto dir = test::ict_dir();
  if (!test::require_data(dir / "generic_neutral_mesh.obj")) return;
  const rig::Rig rig = rig::read_obj_shapes(dir / "generic_neutral_mesh.obj", dir, {"identity*"});
  const Renderer r(rig, small());
  check_golden(r.render(weights_for(rig, {})), "ict_neutral");
  check_golden(r.render(weights_for(
                   rig, {{"jawOpen", 0.8f}, {"mouthSmile_L", 0.6f}, {"mouthSmile_R", 0.6f}})),
               "ict_open_smile");
}

TEST_CASE("blending on the GPU matches blending on the CPU", "[render]") {
  const rig::Rig& rig = avatar::default_avatar();
  const auto named = std::vector<std::pair<std::string, float>>{
      {"jawOpen", 0.6f}, {"mouthSmileLeft", 0.8f}, {"eyeBlinkRight", 1.0f}, {"browInnerUp", 0.7f}};
  const std::vector<float> w = weights_for(rig, named);
  rig::Rig baked = rig;
  rig::Blender(rig).apply(w, baked.positions, baked.normals);
  baked.shapes.clear();
  RenderOptions o = small();
  o.msaa = 0;
  const Renderer gpu(rig, o);
  Renderer cpu(baked, o);
  cpu.set_camera(gpu.camera());
  const ImageDifference d = compare_images(gpu.render(w), cpu.render(std::vector<float>{}));
  INFO("mean " << d.mean_abs << " over " << d.fraction_over);
  CHECK(d.mean_abs < 1.0);
  CHECK(d.fraction_over < 0.005);
}

namespace {

// The level of detail against the full mesh at the default size, in poses that move the lips, lids
// and jaw away from the neutral it was simplified on. Writes full | simplified | difference x4.
void check_lod(const rig::Rig& rig, const std::string& name,
               const std::vector<std::vector<std::pair<std::string, float>>>& poses) {
  RenderOptions o;
  const Renderer lod(rig, o);
  o.lod_pixels = 0;
  const Renderer full(rig, o);
  const auto [triangles, drawn] = lod.triangle_counts();
  INFO(name << ": " << drawn << " of " << triangles << " triangles drawn");
  CHECK(drawn * 5 < triangles * 2);  // under 40 %
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const std::vector<float> w = weights_for(rig, poses[i]);
    const Image a = full.render(w), b = lod.render(w);
    const ImageDifference d = compare_images(a, b);
    Image diff = a, strip{a.width * 3, a.height, 3, {}};
    for (std::size_t k = 0; k < diff.pixels.size(); ++k)
      diff.pixels[k] = static_cast<std::uint8_t>(
          std::min(255, 4 * std::abs(int{a.pixels[k]} - int{b.pixels[k]})));
    strip.pixels.resize(static_cast<std::size_t>(strip.width) * strip.height * 3);
    for (int y = 0; y < a.height; ++y)
      for (int part = 0; part < 3; ++part) {
        const Image& from = part == 0 ? a : part == 1 ? b : diff;
        std::copy_n(
            &from.pixels[static_cast<std::size_t>(y) * a.width * 3], a.width * 3,
            &strip.pixels[(static_cast<std::size_t>(y) * strip.width + part * a.width) * 3]);
      }
    write_image(test::artifacts_dir("render") / (name + "_lod_" + std::to_string(i) + ".png"),
                strip);
    INFO("pose " << i << ": mean " << d.mean_abs << ", over 32: " << d.fraction_over << ", max "
                 << d.max_abs);
    std::cout << name << " pose " << i << ": " << drawn << "/" << triangles << " triangles, mean "
              << d.mean_abs << ", over 32: " << d.fraction_over << ", max " << d.max_abs << "\n";
    CHECK(d.max_abs > 0);  // the simplified mesh is what was drawn
    CHECK(d.mean_abs < 0.6);
    CHECK(d.fraction_over < 0.002);
  }
}

}  // namespace

TEST_CASE("the level of detail renders like the full mesh", "[render]") {
  check_lod(avatar::default_avatar(), "avatar",
            {{},
             {{"jawOpen", 1.0f}, {"mouthSmileLeft", 1.0f}, {"mouthSmileRight", 1.0f}},
             {{"eyeBlinkLeft", 1.0f}, {"eyeBlinkRight", 1.0f}, {"browInnerUp", 1.0f}},
             {{"mouthFunnel", 1.0f}, {"mouthPucker", 0.6f}, {"jawOpen", 0.3f}}});
  const auto dir = test::ict_dir();
  if (!test::require_data(dir / "generic_neutral_mesh.obj")) return;
  check_lod(rig::read_obj_shapes(dir / "generic_neutral_mesh.obj", dir, {"identity*"}), "ict",
            {{},
             {{"jawOpen", 1.0f}, {"mouthSmile_L", 1.0f}, {"mouthSmile_R", 1.0f}},
             {{"eyeBlink_L", 1.0f}, {"eyeBlink_R", 1.0f}, {"browInnerUp_L", 1.0f}},
             {{"mouthFunnel", 1.0f}, {"mouthPucker", 0.6f}, {"jawOpen", 0.3f}}});
}

TEST_CASE("a renderer is shared by threads", "[render]") {
  const rig::Rig& rig = avatar::default_avatar();
  RenderOptions o = small();
  o.contexts = 2;
  const Renderer r(rig, o);
  const std::vector<float> w = weights_for(rig, {{"jawOpen", 0.5f}});
  const Image ref = r.render(w);
  std::vector<Image> out(4);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      for (int i = 0; i < 3; ++i) out[static_cast<std::size_t>(t)] = r.render(w);
    });
  for (auto& t : threads) t.join();
  for (const auto& img : out) CHECK(img.pixels == ref.pixels);
  CHECK(r.backend().find("EGL") == 0);
}

TEST_CASE("images: JPEG in memory, PNG/JPEG/EXR files, bad input", "[render]") {
  const rig::Rig& rig = avatar::default_avatar();
  const Renderer r(rig, small());
  const Image img = r.render(weights_for(rig, {}));
  const std::string jpeg = encode_jpeg(img, 80);
  REQUIRE(jpeg.size() > 1000);
  CHECK(static_cast<unsigned char>(jpeg[0]) == 0xFF);
  CHECK(static_cast<unsigned char>(jpeg[1]) == 0xD8);
  for (const char* name : {"x.png", "x.jpg", "x.exr"}) {
    const auto path = test::scratch_dir() / name;
    write_image(path, img);
    const Image back = read_image(path);
    CHECK(back.width == img.width);
    CHECK(compare_images(back, img).mean_abs < 3.0);
  }
  CHECK_THROWS_AS(write_image(test::scratch_dir() / "x.bmpx", img), Error);
  CHECK_THROWS_AS(r.render(std::vector<float>{1.0f}), Error);
  CHECK_THROWS_AS(weights_for(rig, {{"noSuchShape", 1.0f}}), Error);
  CHECK_THROWS_AS(parse_weight_list("jawOpen=abc"), Error);
  CHECK_THROWS_AS(parse_weight_list("jawOpen"), Error);
  const auto parsed = parse_weight_list(" jawOpen=0.7, mouthSmileLeft = 1 ,");
  REQUIRE(parsed.size() == 2);
  CHECK(parsed[1].first == "mouthSmileLeft");
  CHECK(parsed[1].second == 1.0f);
}

TEST_CASE("photos are turned upright by their EXIF orientation", "[render]") {
  // Stored 64 x 48: its top-left 16 x 16 corner red, its top-right green, the rest grey.
  Image stored{64, 48, 3, std::vector<std::uint8_t>(64 * 48 * 3, 128)};
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x)
      for (int c = 0; c < 3; ++c) {
        stored.pixels[(static_cast<std::size_t>(y) * 64 + x) * 3 + c] = c == 0 ? 230 : 20;
        stored.pixels[(static_cast<std::size_t>(y) * 64 + 63 - x) * 3 + c] = c == 1 ? 230 : 20;
      }
  const std::string jpeg = encode_jpeg(stored, 95);
  // Where the stored top-left and top-right corners are shown (EXIF 2.3, Orientation: "the 0th
  // row is the visual top / right-hand side ..."), as (right?, bottom?) of the shown picture.
  struct Corner {
    bool right, bottom;
  };
  const std::pair<Corner, Corner> shown[8] = {
      {{false, false}, {true, false}}, {{true, false}, {false, false}},   // 1, 2
      {{true, true}, {false, true}},   {{false, true}, {true, true}},     // 3, 4
      {{false, false}, {false, true}}, {{true, false}, {true, true}},     // 5, 6
      {{true, true}, {true, false}},   {{false, true}, {false, false}}};  // 7, 8
  for (int o = 1; o <= 8; ++o) {
    INFO("orientation " << o);
    const std::string tagged = test::with_exif_orientation(jpeg, o);
    const auto file = test::scratch_dir() / ("oriented" + std::to_string(o) + ".jpg");
    write_file_atomic(file, tagged);
    for (const Image& photo : {decode_photo(tagged, "photo"), read_photo(file)}) {
      REQUIRE(photo.channels == 3);
      CHECK(photo.width == (o >= 5 ? 48 : 64));
      CHECK(photo.height == (o >= 5 ? 64 : 48));
      const auto colour_at = [&](Corner k) {
        const int x = k.right ? photo.width - 8 : 7, y = k.bottom ? photo.height - 8 : 7;
        return std::array<int, 3>{photo.at(x, y, 0), photo.at(x, y, 1), photo.at(x, y, 2)};
      };
      const auto red = colour_at(shown[o - 1].first), green = colour_at(shown[o - 1].second);
      CHECK(red[0] > 180);
      CHECK(red[1] < 70);
      CHECK(green[1] > 180);
      CHECK(green[0] < 70);
    }
    // decode_image and read_image keep the stored pixels (an avatar's textures are not turned).
    CHECK(decode_image(tagged, "texture").width == 64);
    CHECK(read_image(file).width == 64);
  }
  CHECK(apply_orientation(stored, 0).pixels == stored.pixels);  // out of range: as stored
  CHECK(apply_orientation(stored, 9).pixels == stored.pixels);
}

TEST_CASE("a photo's EXIF 35-mm focal length is written and read back", "[render]") {
  Image photo{48, 64, 3, std::vector<std::uint8_t>(48 * 64 * 3, 128)};
  photo.focal_35mm = 26.4;  // a phone's main camera; EXIF keeps whole millimetres
  const std::string jpeg = encode_jpeg(photo, 90);
  CHECK(decode_photo(jpeg, "photo").focal_35mm == 26);
  const auto file = test::scratch_dir() / "focal.jpg";
  write_image(file, photo);
  CHECK(read_photo(file).focal_35mm == 26);
  CHECK(scale_down(read_photo(file), 0.5).focal_35mm == 26);  // the same angle of view
  // None given, none in the file; a value no lens has is ignored.
  photo.focal_35mm = 0;
  CHECK(decode_photo(encode_jpeg(photo), "photo").focal_35mm == 0);
  CHECK(decode_photo(encode_png(photo), "photo").focal_35mm == 0);
  photo.focal_35mm = 9000;
  CHECK(decode_photo(encode_jpeg(photo), "photo").focal_35mm == 0);
}

TEST_CASE("images are scaled down by the mean of the pixels each covers", "[render]") {
  // 5 x 3, RGBA, each channel a function of the pixel: halved to 3 x 2 (the size rounded), the
  // output pixel (x, y) is the mean of the source's [2x, 2x + 2) x [2y, 2y + 2), cut at the edge.
  Image image{5, 3, 4, {}};
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 5; ++x)
      for (int c = 0; c < 4; ++c)
        image.pixels.push_back(static_cast<std::uint8_t>(10 * x + 50 * y + c));
  const Image half = scale_down(image, 0.5);
  REQUIRE(half.width == 3);
  REQUIRE(half.height == 2);
  REQUIRE(half.channels == 4);
  const auto mean = [&](int x, int y, int c) {
    int sum = 0, n = 0;
    for (int yy = 2 * y; yy < std::min(2 * y + 2, 3); ++yy)
      for (int xx = 2 * x; xx < std::min(2 * x + 2, 5); ++xx, ++n) sum += image.at(xx, yy, c);
    return sum / n;
  };
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 3; ++x)
      for (int c = 0; c < 4; ++c) CHECK(half.at(x, y, c) == mean(x, y, c));
  CHECK(scale_down(image, 1.0).pixels == image.pixels);
  CHECK_THROWS_WITH(scale_down(image, 0), Catch::Contains("scale must be in (0, 1]"));
  CHECK_THROWS(scale_down(image, 1.5));
}
