// Avatars as every render path draws them. Textures and materials as the web ships them: WebP
// (EXT_texture_webp, written by gltf-transform) renders like the PNG original; KTX2
// (KHR_texture_basisu) falls back to the core image when it is optional and is refused in one line
// naming the conversion when required or alone; unlit and emissive-strength materials; OBJ texture
// coordinates with v = 0 at the image's bottom. The CLI's render draws every mesh, framed face,
// bust or full, standing in the rest pose.
#include <tiny_gltf.h>

#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "build_paths.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/render/image.hpp"
#include "facecast/render/renderer.hpp"
#include "facecast/rig/avatar_document.hpp"
#include "facecast/rig/decode_limits.hpp"
#include "facecast/rig/rest_pose.hpp"
#include "facecast/rig/rig_io.hpp"
#include "humanoid.hpp"
#include "test_avatar_file.hpp"
#include "test_data.hpp"

using namespace facecast;
namespace fs = std::filesystem;

namespace {

fs::path render_dir() {
  const fs::path dir = facecast::test::build_dir() / "tests/rig" / "avatar-render";
  fs::create_directories(dir);
  return dir;
}

render::Image front(const rig::Rig& rig) {
  render::RenderOptions o;
  o.width = o.height = 128;
  o.framing = render::Framing::kFace;
  o.contexts = 1;
  const std::vector<float> neutral(rig.shapes.size(), 0.0f);
  return render::Renderer(rig, o).render(neutral);
}

// The test avatar with its document edited by `edit`, written and read back as a file would be.
rig::Rig edited(const std::string& name, void (*edit)(tinygltf::Model&)) {
  rig::AvatarDocument doc = rig::AvatarDocument::parse(test::test_avatar_glb(), name);
  edit(doc.model());
  const fs::path path = render_dir() / name;
  doc.write_glb(path);
  return rig::load_rig(path);
}

// A KTX2 file's header (identifier, vkFormat, type size, 64 x 64 pixels): enough for the loader,
// which reads only the header; no decoder here takes the payload.
std::string ktx2_bytes() {
  std::string b("\xabKTX 20\xbb\r\n\x1a\n", 12);
  b.resize(80, '\0');
  b[20] = 64;  // pixelWidth
  b[24] = 64;  // pixelHeight
  return b;
}

// Adds the KTX2 image as KHR_texture_basisu's source of texture 0; `keep_fallback` keeps the PNG
// as the core source.
void add_basisu(tinygltf::Model& m, bool keep_fallback) {
  const std::string bytes = ktx2_bytes();
  tinygltf::Buffer& buffer = m.buffers[0];
  while (buffer.data.size() % 4) buffer.data.push_back(0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = buffer.data.size();
  view.byteLength = bytes.size();
  buffer.data.insert(buffer.data.end(), bytes.begin(), bytes.end());
  m.bufferViews.push_back(view);
  tinygltf::Image image;
  image.mimeType = "image/ktx2";
  image.bufferView = static_cast<int>(m.bufferViews.size()) - 1;
  m.images.push_back(image);
  tinygltf::Value::Object source;
  source["source"] = tinygltf::Value(static_cast<int>(m.images.size()) - 1);
  m.textures[0].extensions["KHR_texture_basisu"] = tinygltf::Value(source);
  if (!keep_fallback) m.textures[0].source = -1;
  m.extensionsUsed.push_back("KHR_texture_basisu");
}

// The covered pixels' bounding box (the background is the corner's colour).
struct Extent {
  int x0 = 1 << 20, y0 = 1 << 20, x1 = -1, y1 = -1;
  int width() const { return x1 - x0 + 1; }
  int height() const { return y1 - y0 + 1; }
};
Extent covered(const render::Image& img) {
  Extent e;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      int d = 0;
      for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(img.at(x, y, c) - img.at(0, 0, c)));
      if (d <= 6) continue;
      e = {std::min(e.x0, x), std::min(e.y0, y), std::max(e.x1, x), std::max(e.y1, y)};
    }
  return e;
}

// `facecast render --rig <path> <args> --size 160x160 --out <name>.png`, read back.
render::Image render_cli(const fs::path& rig, const std::string& name, const std::string& args) {
  const fs::path out = rig.parent_path() / (name + ".png");
  const std::string cmd = facecast::test::facecast_exe().string() + " render --rig '" +
                          rig.string() + "' " + args + " --size 160x160 --out '" + out.string() +
                          "' > '" + out.string() + ".log' 2>&1";
  INFO(cmd);
  REQUIRE(std::system(cmd.c_str()) == 0);
  return render::read_image(out);
}

}  // namespace

TEST_CASE("a WebP-textured avatar renders like its PNG-textured original", "[rig][gltf][texture]") {
  const fs::path dir = render_dir();
  write_file_atomic(dir / "base.glb", test::test_avatar_glb());
  const fs::path webp = dir / "webp.glb";
  const std::string cmd = facecast::test::source_dir().string() +
                          "/node_modules/.bin/gltf-transform webp '" + (dir / "base.glb").string() +
                          "' '" + webp.string() + "' > '" + webp.string() + ".log' 2>&1";
  INFO(cmd);
  REQUIRE(std::system(cmd.c_str()) == 0);
  const std::string bytes = read_file(webp);
  CHECK_THAT(bytes, Catch::Contains("EXT_texture_webp"));

  const rig::Rig png = rig::load_rig(dir / "base.glb"), web = rig::load_rig(webp);
  REQUIRE(web.textures.size() == png.textures.size());
  for (const auto& t : web.textures) CHECK(t.bytes.substr(8, 4) == "WEBP");
  const render::Image a = front(png), b = front(web);
  const render::ImageDifference d = render::compare_images(a, b, 24);
  INFO("mean " << d.mean_abs << ", max " << d.max_abs << ", over 24: " << d.fraction_over);
  CHECK(d.mean_abs < 3.0);
  CHECK(d.fraction_over < 0.01);

  // Written back as a rig, the WebP texture keeps its extension (required: there is no fallback).
  const std::string written = rig::glb_bytes(web);
  CHECK_THAT(written, Catch::Contains("\"extensionsRequired\":[\"EXT_texture_webp\"]"));
  const render::Image c = front(rig::parse_glb(written, "written.glb"));
  CHECK(render::compare_images(b, c, 0).max_abs == 0);

  // A corrupt WebP payload is one clear line at render time.
  rig::Rig broken = web;
  broken.textures[0].bytes.resize(broken.textures[0].bytes.size() / 2);
  CHECK_THROWS_WITH(front(broken), Catch::Contains("texture 0") && Catch::Contains("WebP"));
}

TEST_CASE("KTX2 textures: the fallback when optional, one line naming the conversion otherwise",
          "[rig][gltf][texture]") {
  const rig::Rig base = rig::load_rig([] {
    const fs::path p = render_dir() / "base.glb";
    write_file_atomic(p, test::test_avatar_glb());
    return p;
  }());
  SECTION("optional with a PNG fallback: the fallback is used") {
    const rig::Rig r =
        edited("basisu_optional.glb", [](tinygltf::Model& m) { add_basisu(m, true); });
    CHECK(r.textures[0].bytes == base.textures[0].bytes);
    CHECK(render::compare_images(front(base), front(r), 0).max_abs == 0);
  }
  SECTION("required: refused when the file is read") {
    CHECK_THROWS_WITH(edited("basisu_required.glb",
                             [](tinygltf::Model& m) {
                               add_basisu(m, false);
                               m.extensionsRequired.push_back("KHR_texture_basisu");
                             }),
                      Catch::Contains("basisu_required.glb") &&
                          Catch::Contains("KHR_texture_basisu") &&
                          Catch::Contains("gltf-transform png"));
  }
  SECTION("optional without a fallback: refused when the texture is decoded") {
    const rig::Rig r = edited("basisu_alone.glb", [](tinygltf::Model& m) { add_basisu(m, false); });
    CHECK(r.textures[0].bytes == ktx2_bytes());
    CHECK_THROWS_WITH(front(r), Catch::Contains("texture 0") && Catch::Contains("KTX2") &&
                                    Catch::Contains("gltf-transform png"));
  }
}

TEST_CASE("unlit and emissive-strength materials", "[rig][gltf][texture]") {
  const rig::Rig r = edited("materials.glb", [](tinygltf::Model& m) {
    for (auto& mat : m.materials) {
      mat.extensions["KHR_materials_unlit"] = tinygltf::Value(tinygltf::Value::Object{});
      mat.pbrMetallicRoughness.baseColorTexture.index = -1;
      mat.pbrMetallicRoughness.baseColorFactor = {0.5, 0.2, 0.1, 1.0};
    }
    m.materials[0].emissiveFactor = {1.0, 0.5, 0.0};
    tinygltf::Value::Object strength;
    strength["emissiveStrength"] = tinygltf::Value(3.0);
    m.materials[0].extensions["KHR_materials_emissive_strength"] = tinygltf::Value(strength);
    m.extensionsUsed.push_back("KHR_materials_unlit");
    m.extensionsUsed.push_back("KHR_materials_emissive_strength");
  });
  REQUIRE(r.materials.size() == 4);
  CHECK(r.materials[0].unlit);
  CHECK(r.materials[0].emissive.isApprox(Eigen::Vector3f(3.0f, 1.5f, 0.0f)));
  // Unlit: every covered pixel is the base colour in sRGB (0.5, 0.2, 0.1 -> 188, 124, 89),
  // whatever the light and the normal map say.
  const render::Image img = front(r);
  int covered = 0, exact = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const Eigen::Vector3i p(img.at(x, y, 0), img.at(x, y, 1), img.at(x, y, 2));
      if ((p - Eigen::Vector3i(188, 124, 89)).cwiseAbs().maxCoeff() <= 2) ++exact;
      if (std::abs(p.x() - p.z()) > 40) ++covered;  // the background is grey
    }
  INFO(exact << " of " << covered << " covered pixels");
  CHECK(covered > 1000);
  CHECK(exact > 0.97 * covered);
  // Written back, both extensions stay.
  const rig::Rig back = rig::parse_glb(rig::glb_bytes(r), "back.glb");
  CHECK(back.materials[0].unlit);
  CHECK(back.materials[0].emissive.isApprox(r.materials[0].emissive));
}

TEST_CASE("OBJ texture coordinates have v = 0 at the image's bottom", "[rig][obj][texture]") {
  // A quad facing +Z textured with an image red on top, blue below; its top vertices at v = 1.
  const fs::path dir = render_dir() / "obj";
  fs::create_directories(dir);
  render::Image tex{8, 8, 4, {}};
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x)
      for (const int c : {y < 4 ? 230 : 30, 30, y < 4 ? 30 : 230, 255})
        tex.pixels.push_back(static_cast<std::uint8_t>(c));
  write_file_atomic(dir / "quad.png", render::encode_png(tex));
  write_file_atomic(dir / "quad.mtl", "newmtl paint\nKd 1 1 1\nmap_Kd quad.png\n");
  write_file_atomic(dir / "quad.obj",
                    "mtllib quad.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n"
                    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl paint\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n");
  const rig::Rig quad = rig::read_obj(dir / "quad.obj");
  CHECK(quad.uvs(2, 1) == 0.0f);  // glTF's convention inside: v = 0 at the top
  const render::Image img = front(quad);
  const auto red = [&](int y) { return img.at(img.width / 2, y, 0) - img.at(img.width / 2, y, 2); };
  CHECK(red(img.height / 2 - 10) > 100);   // the quad's top half: red
  CHECK(red(img.height / 2 + 10) < -100);  // its bottom half: blue
  // Written as OBJ again, the coordinates are the file's.
  rig::write_obj(dir / "again.obj", quad);
  const std::string again = read_file(dir / "again.obj");
  CHECK_THAT(again, Catch::Contains("vt 1 1\n") && Catch::Contains("vt 0 0\n"));
}

TEST_CASE("the CLI's render draws every mesh of the avatar, framed face, bust or full",
          "[rig][gltf][render]") {
  const fs::path dir = render_dir() / "scene";
  fs::create_directories(dir);
  write_file_atomic(dir / "avatar.glb", test::test_avatar_glb());
  const auto render_framed = [&](const std::string& framing) {
    return render_cli(dir / "avatar.glb", framing, "--framing " + framing);
  };
  // Full: hair (top, 2.15 m) to body (bottom, 0.9 m) over the head's 0.6 m width: a tall figure.
  const Extent full = covered(render_framed("full"));
  INFO("full: " << full.width() << "x" << full.height());
  CHECK(full.height() > 1.6 * full.width());
  // Bust: the body shows below the head, into the frame's bottom quarter (the head alone ends
  // above its middle).
  const render::Image bust = render_framed("bust");
  CHECK(covered(bust).y1 > 0.75 * bust.height);
  // Face: the hair card in front of the head's top is drawn (the face view alone has no hair).
  const render::Image face = render_framed("face");
  render::RenderOptions o;
  o.width = o.height = 160;
  o.msaa = 4;  // as the CLI renders a pose
  o.contexts = 1;
  const rig::Rig head = rig::load_rig(dir / "avatar.glb");
  const render::Image bald =
      render::Renderer(head, o).render(std::vector<float>(head.shapes.size(), 0.0f));
  const double hair = render::compare_images(face, bald, 24).fraction_over;
  INFO("pixels that differ from the bald face view: " << hair);
  CHECK(hair > 0.05);
  CHECK(rig::load_scene(dir / "avatar.glb").shape_names() == head.shape_names());
}

TEST_CASE("an avatar saved in T-pose renders standing with its arms down", "[rig][gltf][render]") {
  const fs::path dir = render_dir() / "pose";
  fs::create_directories(dir);
  rig::write_glb(dir / "tpose.glb", test::humanoid(0));
  const Extent rest = covered(render_cli(dir / "tpose.glb", "rest", "--framing full"));
  const Extent bind = covered(render_cli(dir / "tpose.glb", "bind", "--framing full --pose bind"));
  INFO("rest " << rest.width() << "x" << rest.height() << ", bind " << bind.width() << "x"
               << bind.height());
  CHECK(bind.width() > bind.height());
  CHECK(rest.width() < 0.7 * rest.height());
  // A pose file: the right arm down by its joint's name, the left raised 30 degrees above the
  // horizontal by its VRM name -- wider than the rest pose, the raised hand above the shoulders.
  std::ofstream(dir / "wave.json") << R"({"mixamorig:RightArm": {"euler_deg": [0, 0, 80]},
                                         "leftUpperArm": {"euler_deg": [0, 0, 30]}})";
  const Extent wave = covered(render_cli(
      dir / "tpose.glb", "wave", "--framing full --pose '" + (dir / "wave.json").string() + "'"));
  INFO("wave " << wave.width() << "x" << wave.height());
  CHECK(wave.width() > 1.3 * rest.width());
  CHECK(wave.width() < bind.width());
  // "head" names the head joint of an avatar without a VRM humanoid (Mixamo's "mixamorig:Head").
  std::ofstream(dir / "turn.json") << R"({"head": {"euler_deg": [0, 90, 0]}})";
  CHECK(std::system((facecast::test::facecast_exe().string() + " render --rig '" +
                     (dir / "tpose.glb").string() + "' --pose '" + (dir / "turn.json").string() +
                     "' --out '" + (dir / "turn.png").string() + "'")
                        .c_str()) == 0);
  CHECK(std::system((facecast::test::facecast_exe().string() + " render --rig '" +
                     (dir / "tpose.glb").string() + "' --pose sit --out x.png 2>/dev/null")
                        .c_str()) != 0);
}

TEST_CASE("the idle body breathes, shrugs and leans in renders; a rig without a skeleton does not",
          "[rig][render][body]") {
  rig::Rig figure = test::humanoid(0);
  rig::apply_rest_pose(figure);
  render::RenderOptions o;
  o.width = o.height = 160;
  o.framing = render::Framing::kFull;
  o.contexts = 1;
  const render::Renderer renderer(figure, o);
  const std::vector<float> neutral(figure.shapes.size(), 0.0f);
  const auto draw = [&](float breath, float lean, float shrug) {
    rig::BodyPose pose;
    pose.breath = breath, pose.lean = lean, pose.shrug = shrug;
    return renderer.render(neutral, pose);
  };
  const render::Image rest = draw(0, 0, 0);
  const Extent at_rest = covered(rest);
  // The lowest covered row within `columns` of the left or right edge of the figure (a hand).
  const auto hand_bottom = [&](const render::Image& img, bool left) {
    int bottom = -1;
    for (int y = 0; y < img.height; ++y)
      for (int i = 0; i < 6; ++i) {
        const int x = left ? at_rest.x0 + i : at_rest.x1 - i;
        int d = 0;
        for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(img.at(x, y, c) - img.at(0, 0, c)));
        if (d > 6) bottom = y;
      }
    return bottom;
  };
  // The head's columns: the mean x of the covered pixels in the figure's top eighth.
  const auto head_x = [&](const render::Image& img) {
    double sum = 0;
    int n = 0;
    for (int y = at_rest.y0; y < at_rest.y0 + at_rest.height() / 8; ++y)
      for (int x = 0; x < img.width; ++x) {
        int d = 0;
        for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(img.at(x, y, c) - img.at(0, 0, c)));
        if (d > 6) sum += x, ++n;
      }
    return n ? sum / n : -1.0;
  };
  const render::Image shrug = draw(0, 0, 1), breath = draw(1, 0, 0), lean = draw(0, 0.08f, 0);
  INFO("hands' bottom rows at rest " << hand_bottom(rest, true) << "/" << hand_bottom(rest, false)
                                     << ", shrugging " << hand_bottom(shrug, true) << "/"
                                     << hand_bottom(shrug, false) << "; head x at rest "
                                     << head_x(rest) << ", leaning " << head_x(lean));
  // A shrug lifts both hands (rows count down the image) by at least a pixel.
  CHECK(hand_bottom(shrug, true) < hand_bottom(rest, true));
  CHECK(hand_bottom(shrug, false) < hand_bottom(rest, false));
  // A breath turns the chest (its shading changes) and leaves the head where it was.
  CHECK(breath.pixels != rest.pixels);
  CHECK(head_x(breath) == Approx(head_x(rest)).margin(0.5));
  // Leaning to the figure's left (+X) moves its head to the right of the image (seen from the
  // front).
  CHECK(head_x(lean) > head_x(rest) + 1.0);
  // Without a skeleton the body's channels change nothing.
  rig::Rig unskinned = figure;
  unskinned.skeleton = {};
  unskinned.joints.resize(0, 4);
  unskinned.joint_weights.resize(0, 4);
  const render::Renderer plain(unskinned, o);
  rig::BodyPose body;
  body.breath = body.shrug = 1;
  body.lean = 0.08f;
  CHECK(plain.render(neutral, body).pixels == plain.render(neutral).pixels);
}

TEST_CASE("VRM MToon materials are read, 1.0 and 0.x alike", "[rig][gltf][vrm]") {
  const rig::Rig v1 = edited("mtoon1.vrm", [](tinygltf::Model& m) {
    tinygltf::Value::Object mtoon;
    mtoon["shadeColorFactor"] = tinygltf::Value(
        tinygltf::Value::Array{tinygltf::Value(0.1), tinygltf::Value(0.2), tinygltf::Value(0.3)});
    mtoon["shadingShiftFactor"] = tinygltf::Value(-0.2);
    mtoon["shadingToonyFactor"] = tinygltf::Value(0.8);
    mtoon["parametricRimFresnelPowerFactor"] = tinygltf::Value(3.0);
    m.materials[0].extensions["VRMC_materials_mtoon"] = tinygltf::Value(mtoon);
    m.extensionsUsed.push_back("VRMC_materials_mtoon");
  });
  REQUIRE(v1.materials[0].toon);
  CHECK(v1.materials[0].toon->shade_color.isApprox(Eigen::Vector3f(0.1f, 0.2f, 0.3f)));
  CHECK(v1.materials[0].toon->shading_shift == Approx(-0.2));
  CHECK(v1.materials[0].toon->shading_toony == Approx(0.8));
  CHECK(v1.materials[0].toon->rim_fresnel_power == Approx(3.0));
  CHECK_FALSE(v1.materials[1].toon);

  // VRM 0.x: material properties by index, colours in sRGB, _ShadeToony/_ShadeShift migrated as
  // UniVRM does (toony 0.9, shift 0: the range [0, 0.1] -> toony 0.95, shift -0.05).
  const rig::Rig v0 = edited("mtoon0.vrm", [](tinygltf::Model& m) {
    tinygltf::Value::Array props;
    for (std::size_t i = 0; i < m.materials.size(); ++i) {
      tinygltf::Value::Object p, floats, vectors;
      p["name"] = tinygltf::Value(m.materials[i].name);
      p["shader"] = tinygltf::Value(std::string(i == 1 ? "VRM/UnlitTexture" : "VRM/MToon"));
      floats["_ShadeToony"] = tinygltf::Value(0.9);
      floats["_ShadeShift"] = tinygltf::Value(0.0);
      vectors["_ShadeColor"] = tinygltf::Value(tinygltf::Value::Array{
          tinygltf::Value(0.5), tinygltf::Value(0.5), tinygltf::Value(1.0), tinygltf::Value(1.0)});
      p["floatProperties"] = tinygltf::Value(floats);
      p["vectorProperties"] = tinygltf::Value(vectors);
      props.emplace_back(p);
    }
    tinygltf::Value::Object vrm;
    vrm["materialProperties"] = tinygltf::Value(props);
    m.extensions["VRM"] = tinygltf::Value(vrm);
    m.extensionsUsed.push_back("VRM");
  });
  REQUIRE(v0.materials[0].toon);
  CHECK(v0.materials[0].toon->shading_toony == Approx(0.95));
  CHECK(v0.materials[0].toon->shading_shift == Approx(-0.05));
  CHECK(v0.materials[0].toon->shade_color.isApprox(Eigen::Vector3f(0.2140f, 0.2140f, 1.0f), 1e-3f));
  CHECK_FALSE(v0.materials[1].toon);
}
