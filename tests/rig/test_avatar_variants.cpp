// The test avatar as other tools write it (gltf-transform from npm: meshopt, Draco, quantized,
// sparse, .gltf with a separate .bin and PNGs) reads as the original; `rig info --json` lists its
// meshes, names and channels; a VRM with only the five vowel presets speaks through them.
#include <tiny_gltf.h>

#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "build_paths.hpp"
#include "facecast/anim/animation.hpp"
#include "facecast/core/files.hpp"
#include "facecast/rig/avatar_document.hpp"
#include "facecast/rig/avatar_view.hpp"
#include "facecast/rig/rig_io.hpp"
#include "test_avatar_file.hpp"

using namespace facecast;
using namespace facecast::rig;
namespace fs = std::filesystem;

namespace {

fs::path variants_dir() {
  const fs::path dir = facecast::test::build_dir() / "tests/rig" / "avatar-variants";
  fs::create_directories(dir);
  return dir;
}

// Runs `gltf-transform <command> base.glb <out> <args>` in the build tree; returns the output path.
fs::path transform(const std::string& command, const std::string& out,
                   const std::string& args = "") {
  const fs::path dir = variants_dir();
  write_file_atomic(dir / "base.glb", test::test_avatar_glb());
  const fs::path target = dir / out;
  fs::create_directories(target.parent_path());
  const std::string cmd = facecast::test::source_dir().string() +
                          "/node_modules/.bin/gltf-transform " + command + " '" +
                          (dir / "base.glb").string() + "' '" + target.string() + "' " + args +
                          " > '" + target.string() + ".log' 2>&1";
  INFO(cmd);
  REQUIRE(std::system(cmd.c_str()) == 0);
  return target;
}

// Order-independent comparison of two views of the same avatar: triangles, bounds, shape names and
// sizes, texture bytes. Vertex counts may differ (tools split shared vertices).
void check_same_avatar(const Rig& a, const Rig& b, float tolerance) {
  CHECK(a.triangle_count() == b.triangle_count());
  const Eigen::Vector3f a_lo = a.positions.colwise().minCoeff(),
                        a_hi = a.positions.colwise().maxCoeff();
  const Eigen::Vector3f b_lo = b.positions.colwise().minCoeff(),
                        b_hi = b.positions.colwise().maxCoeff();
  CHECK((a_lo - b_lo).cwiseAbs().maxCoeff() < tolerance);
  CHECK((a_hi - b_hi).cwiseAbs().maxCoeff() < tolerance);
  auto names_a = a.shape_names(), names_b = b.shape_names();
  std::sort(names_a.begin(), names_a.end());
  std::sort(names_b.begin(), names_b.end());
  REQUIRE(names_a == names_b);
  for (const auto& s : a.shapes) {
    const auto& t = b.shapes[static_cast<std::size_t>(b.find_shape(s.name))];
    CHECK(std::abs(s.max_displacement() - t.max_displacement()) < tolerance);
  }
  REQUIRE(a.textures.size() == b.textures.size());
  for (std::size_t i = 0; i < a.textures.size(); ++i)
    CHECK(a.textures[i].bytes == b.textures[i].bytes);
  CHECK(a.skeleton.joint_names == b.skeleton.joint_names);
}

nlohmann::json rig_info(const fs::path& path) {
  const fs::path out = path.string() + ".info.json";
  const std::string cmd = facecast::test::facecast_exe().string() + " rig info --json '" +
                          path.string() + "' > '" + out.string() + "'";
  REQUIRE(std::system(cmd.c_str()) == 0);
  return nlohmann::json::parse(read_file(out));
}

}  // namespace

TEST_CASE("compressed, quantized, sparse and split variants read as the original", "[rig][gltf]") {
  const Rig base = make_view(AvatarDocument::parse(test::test_avatar_glb(), "base.glb")).rig;
  SECTION("EXT_meshopt_compression") {
    const fs::path f = transform("meshopt", "meshopt.glb");
    CHECK_THAT(read_file(f), Catch::Contains("EXT_meshopt_compression"));
    check_same_avatar(base, load_rig(f), 2e-3f);
  }
  SECTION("KHR_draco_mesh_compression") {
    const fs::path f = transform("draco", "draco.glb");
    CHECK_THAT(read_file(f), Catch::Contains("KHR_draco_mesh_compression"));
    check_same_avatar(base, load_rig(f), 2e-3f);
  }
  SECTION("KHR_mesh_quantization") {
    const fs::path f = transform("quantize", "quantized.glb");
    CHECK_THAT(read_file(f), Catch::Contains("KHR_mesh_quantization"));
    check_same_avatar(base, load_rig(f), 2e-3f);
  }
  SECTION("sparse accessors") {
    const fs::path f = transform("sparse", "sparse.glb");
    CHECK_THAT(read_file(f), Catch::Contains("\"sparse\""));
    check_same_avatar(base, load_rig(f), 1e-6f);
  }
  SECTION(".gltf with a separate .bin and PNGs: read from disk, refused as an upload") {
    const fs::path f = transform("copy", "split/avatar.gltf");
    check_same_avatar(base, load_rig(f), 1e-6f);
    CHECK_THROWS_WITH(
        parse_glb(read_file(f), "upload.gltf"),
        Catch::Contains("upload.gltf") && Catch::Contains("is not read from an upload"));
  }
}

TEST_CASE("rig info --json lists the meshes with morph targets, names and channels",
          "[rig][gltf]") {
  for (const char* command : {"copy", "meshopt", "draco"}) {
    INFO(command);
    const nlohmann::json j = rig_info(transform(command, std::string(command) + "_info.glb"));
    REQUIRE(j["meshes"].size() == 2);
    int total = 0;
    for (const auto& m : j["meshes"]) {
      total += m["vertices"].get<int>();
      if (m["name"] == "Head")
        CHECK(m["targets"] == nlohmann::json({"jawOpen", "eyeBlinkLeft"}));
      else
        CHECK(m["targets"] == nlohmann::json({"jawOpen"}));
    }
    CHECK(j["vertices"].get<int>() == total);
    CHECK(j["channels"]["table"] == "arkit");
    const auto& shown = j["channels"]["shown"];
    CHECK(std::find(shown.begin(), shown.end(), "viseme.oculus.aa") != shown.end());
    const auto& missing = j["channels"]["missing"];
    CHECK(std::find(missing.begin(), missing.end(), "blink") !=
          missing.end());  // only a left blink
  }
}

TEST_CASE("a VRM with only the vowel presets speaks through them", "[rig][gltf][vrm]") {
  AvatarDocument doc = AvatarDocument::parse(test::test_avatar_glb(), "avatar.vrm");
  auto& m = doc.model();
  // VRoid-like target names; the VRM 0.x blend shape groups name the presets.
  tinygltf::Value::Array head_names{tinygltf::Value(std::string("Fcl_MTH_A")),
                                    tinygltf::Value(std::string("Fcl_EYE_Close"))};
  tinygltf::Value::Object extras;
  extras["targetNames"] = tinygltf::Value(head_names);
  m.meshes[0].extras = tinygltf::Value(extras);
  extras["targetNames"] =
      tinygltf::Value(tinygltf::Value::Array{tinygltf::Value(std::string("Fcl_MTH_A"))});
  m.meshes[1].extras = tinygltf::Value(extras);
  const auto bind = [](int mesh, int index, double weight) {
    tinygltf::Value::Object b;
    b["mesh"] = tinygltf::Value(mesh);
    b["index"] = tinygltf::Value(index);
    b["weight"] = tinygltf::Value(weight);
    return tinygltf::Value(b);
  };
  tinygltf::Value::Array groups;
  const std::pair<const char*, double> vowels[] = {
      {"a", 100}, {"i", 40}, {"u", 30}, {"e", 60}, {"o", 70}};
  for (const auto& [preset, w] : vowels) {
    tinygltf::Value::Object g;
    g["presetName"] = tinygltf::Value(std::string(preset));
    g["binds"] = tinygltf::Value(tinygltf::Value::Array{bind(0, 0, w), bind(1, 0, w)});
    groups.emplace_back(g);
  }
  tinygltf::Value::Object blink;
  blink["presetName"] = tinygltf::Value(std::string("blink"));
  blink["binds"] = tinygltf::Value(tinygltf::Value::Array{bind(0, 1, 100)});
  groups.emplace_back(blink);
  tinygltf::Value::Object master, vrm;
  master["blendShapeGroups"] = tinygltf::Value(groups);
  vrm["blendShapeMaster"] = tinygltf::Value(master);
  m.extensions["VRM"] = tinygltf::Value(vrm);
  m.extensionsUsed.push_back("VRM");
  const fs::path path = variants_dir() / "avatar.vrm";
  doc.write_glb(path);

  const AvatarView view = make_view(AvatarDocument::read(path));
  const Rig& rig = view.rig;
  for (const char* preset : {"aa", "ih", "ou", "ee", "oh", "blink"})
    CHECK(rig.find_shape(preset) >= 0);
  CHECK(view.derived_shapes.size() == 6);
  const auto& aa = rig.shapes[static_cast<std::size_t>(rig.find_shape("aa"))];
  const auto& a = rig.shapes[static_cast<std::size_t>(rig.find_shape("Fcl_MTH_A"))];
  CHECK(aa.max_displacement() == Approx(a.max_displacement()));
  CHECK(rig.shapes[static_cast<std::size_t>(rig.find_shape("ih"))].max_displacement() ==
        Approx(0.4f * a.max_displacement()));

  const auto mapping = facecast::anim::Mapping::for_rig(rig.shape_names());
  CHECK(mapping.table() == "vrm");
  CHECK(mapping.blink_left == rig.find_shape("blink"));
  CHECK(mapping.blink_right == rig.find_shape("blink"));
  // Every vowel and most consonants drive a shape; lip closures rest at the neutral mouth.
  int shown = 0, missing = 0;
  for (const auto& c : mapping.channels()) {
    if (c.name.starts_with("viseme.oculus.")) (c.shown ? shown : missing) += 1;
    if (c.name == "viseme.oculus.aa" || c.name == "viseme.oculus.O") CHECK(c.shown);
  }
  CHECK(shown == 14);
  CHECK(missing == 1);  // PP
  const nlohmann::json j = rig_info(path);
  CHECK(j["channels"]["table"] == "vrm");
}
