// The avatar document and its view: load -> save keeps everything (Khronos validator clean, images
// byte for byte), the view merges meshes in the bind pose with targets by name, materials,
// textures and the skeleton, and shapes written back land in the right primitives.
#include <tiny_gltf.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>

#include "build_paths.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/rig/avatar_document.hpp"
#include "facecast/rig/avatar_view.hpp"
#include "facecast/rig/rig_io.hpp"
#include "test_avatar_file.hpp"

using namespace facecast;
using namespace facecast::rig;
namespace fs = std::filesystem;

namespace {

fs::path work_dir() {
  const fs::path dir = facecast::test::build_dir() / "tests/rig" / "avatar-files";
  fs::create_directories(dir);
  return dir;
}

// The Khronos glTF validator's verdict on `path` (0 errors -> true).
bool validator_clean(const fs::path& path) {
  const std::string cmd = "node " + facecast::test::source_dir().string() +
                          "/scripts/validate-gltf.mjs '" + path.string() + "' > '" + path.string() +
                          ".validation' 2>&1";
  const int rc = std::system(cmd.c_str());
  if (rc != 0) UNSCOPED_INFO(read_file(path.string() + ".validation"));
  return rc == 0;
}

std::string image_bytes(const tinygltf::Model& m, int i) {
  const auto& im = m.images[static_cast<std::size_t>(i)];
  const auto& v = m.bufferViews[static_cast<std::size_t>(im.bufferView)];
  const auto& b = m.buffers[static_cast<std::size_t>(v.buffer)].data;
  return std::string(reinterpret_cast<const char*>(b.data() + v.byteOffset), v.byteLength);
}

// The view's part of mesh `name` (its first primitive).
const ViewPart& part_of(const AvatarView& view, const std::string& name) {
  for (const auto& p : view.parts)
    if (p.mesh_name == name) return p;
  FAIL("no part " << name);
  return view.parts.front();
}

const ViewMesh& mesh_of(const AvatarView& view, const std::string& name) {
  for (const auto& m : view.meshes)
    if (m.name == name) return m;
  FAIL("no mesh " << name);
  return view.meshes.front();
}

std::vector<std::string> sorted(std::vector<std::string> v) {
  std::sort(v.begin(), v.end());
  return v;
}

}  // namespace

TEST_CASE("load -> save keeps every part of a multi-mesh skinned textured GLB", "[rig][gltf]") {
  const std::string base = test::test_avatar_glb();
  write_file_atomic(work_dir() / "base.glb", base);
  REQUIRE(validator_clean(work_dir() / "base.glb"));

  const AvatarDocument doc = AvatarDocument::parse(base, "base.glb");
  const std::string saved = doc.glb_bytes();
  write_file_atomic(work_dir() / "saved.glb", saved);
  CHECK(validator_clean(work_dir() / "saved.glb"));

  const AvatarDocument again = AvatarDocument::parse(saved, "saved.glb");
  const tinygltf::Model &a = doc.model(), &b = again.model();
  CHECK(b.nodes.size() == 8);
  CHECK(b.nodes.size() == a.nodes.size());
  CHECK(b.meshes.size() == 4);
  CHECK(b.skins.size() == 1);
  CHECK(b.skins[0].joints == a.skins[0].joints);
  CHECK(b.animations.size() == 1);
  CHECK(b.materials.size() == 4);
  CHECK(b.samplers.size() == 1);
  REQUIRE(b.images.size() == 2);
  for (int i = 0; i < 2; ++i) CHECK(image_bytes(b, i) == test::test_avatar_png(i));
  CHECK(b.extensionsUsed == a.extensionsUsed);
  CHECK(b.nodes[3].extensions.at("EXT_facecast_test").Get("answer").GetNumberAsInt() == 42);
  CHECK(b.nodes[3].extras.Get("creator").Get<std::string>() == "facecast tests");
  CHECK(b.materials[0].pbrMetallicRoughness.baseColorTexture.extensions.count(
      "KHR_texture_transform"));
  for (std::size_t mi = 0; mi < a.meshes.size(); ++mi) {
    CHECK(b.meshes[mi].name == a.meshes[mi].name);
    CHECK(b.meshes[mi].primitives.size() == a.meshes[mi].primitives.size());
  }
}

TEST_CASE("the view merges the meshes with morph targets in the bind pose", "[rig][gltf]") {
  const AvatarDocument doc = AvatarDocument::parse(test::test_avatar_glb(), "base.glb");
  const AvatarView view = make_view(doc);
  const Rig& rig = view.rig;
  CHECK(rig.vertex_count() == 35 + 6);  // Head (7x5) and Teeth (3x2); Hair and Body have no morphs
  CHECK(sorted(rig.groups) == std::vector<std::string>{"Head", "Teeth"});
  REQUIRE(view.meshes.size() == 2);
  CHECK(mesh_of(view, "Head").targets == std::vector<std::string>{"jawOpen", "eyeBlinkLeft"});
  CHECK(mesh_of(view, "Head").vertices == 35);
  CHECK(mesh_of(view, "Teeth").targets == std::vector<std::string>{"jawOpen"});
  CHECK(sorted(rig.shape_names()) == std::vector<std::string>{"eyeBlinkLeft", "jawOpen"});

  // Teeth: node under the Head joint (y 1.7), translated (0, -0.1, 0.08) and scaled 2.
  const int t0 = part_of(view, "Teeth").first_vertex, h0 = part_of(view, "Head").first_vertex;
  CHECK(rig.positions(t0, 0) == Approx(-0.1f));
  CHECK(rig.positions(t0, 1) == Approx(1.6f));
  CHECK(rig.positions(t0, 2) == Approx(0.08f));
  // jawOpen moves head and teeth; the teeth delta went through the node's scale.
  const Positions jaw =
      rig.shapes[static_cast<std::size_t>(rig.find_shape("jawOpen"))].dense(rig.vertex_count());
  CHECK(jaw(t0, 1) == Approx(-0.08f));
  CHECK(jaw.middleRows(h0, 35).cwiseAbs().maxCoeff() > 0.04f);
  CHECK(rig.shapes[static_cast<std::size_t>(rig.find_shape("eyeBlinkLeft"))]
            .dense(rig.vertex_count())
            .middleRows(t0, 6)
            .isZero());

  // Materials and textures as the file has them.
  REQUIRE(rig.materials.size() == 4);
  const Material& skin = rig.materials[0];
  CHECK(skin.roughness == Approx(0.7f));
  CHECK(skin.base_color_texture.texture == 0);
  CHECK(skin.base_color_texture.offset.isApprox(Eigen::Vector2f(0.25f, 0.5f)));
  CHECK(skin.base_color_texture.scale.isApprox(Eigen::Vector2f(2.0f, 2.0f)));
  CHECK(skin.base_color_texture.rotation == Approx(0.5f));
  CHECK(skin.normal_texture.texture == 1);
  CHECK(skin.normal_texture.strength == Approx(0.8f));
  CHECK(rig.materials[3].alpha_mode == AlphaMode::kMask);
  CHECK(rig.materials[3].double_sided);
  REQUIRE(rig.textures.size() == 2);
  CHECK(rig.textures[0].bytes == test::test_avatar_png(0));
  CHECK(rig.textures[0].mime_type == "image/png");
  CHECK_FALSE(rig.textures[0].repeat_s);
  CHECK(rig.textures[0].repeat_t);

  // The skeleton, head and neck found by name; the teeth follow the Head joint.
  const Skeleton& sk = rig.skeleton;
  REQUIRE(sk.joint_names.size() == 4);
  REQUIRE(sk.head >= 0);
  CHECK(sk.joint_names[static_cast<std::size_t>(sk.head)] == "Head");
  CHECK(sk.joint_names[static_cast<std::size_t>(sk.neck)] == "Neck");
  CHECK(sk.parent[static_cast<std::size_t>(sk.head)] == sk.neck);
  CHECK(sk.rest_origin[static_cast<std::size_t>(sk.head)].y() == Approx(1.7f));
  REQUIRE(rig.joints.rows() == rig.vertex_count());
  CHECK(rig.joints(t0, 0) == sk.head);
  CHECK(rig.joint_weights(t0, 0) == 1.0f);

  const AvatarView all = make_view(doc, {.all_meshes = true});
  CHECK(all.rig.vertex_count() == 35 + 6 + 9 + 12);
  CHECK(sorted(all.rig.groups) == std::vector<std::string>{"Body", "Hair", "Head", "Teeth"});
  CHECK(all.rig.shape_names() == rig.shape_names());
  CHECK(all.rig.joints.rows() == all.rig.vertex_count());
}

TEST_CASE("the view applies the skin where the file's joints are", "[rig][gltf]") {
  AvatarDocument doc = AvatarDocument::parse(test::test_avatar_glb(), "base.glb");
  const Rig rest = make_view(doc).rig;
  doc.model().nodes[3].translation[1] +=
      1.0;  // Hips up by 1: everything skinned or parented follows
  const Rig moved = make_view(doc).rig;
  CHECK((moved.positions.col(1) - rest.positions.col(1)).isApproxToConstant(1.0f, 1e-5f));
}

TEST_CASE("shapes written back land in their primitives and survive a save", "[rig][gltf]") {
  AvatarDocument doc = AvatarDocument::parse(test::test_avatar_glb(), "base.glb");
  const AvatarView view = make_view(doc);
  Rig rig = view.rig;
  const int nv = rig.vertex_count();
  Positions smile = Positions::Zero(nv, 3);
  smile(part_of(view, "Head").first_vertex + 3, 0) = 0.01f;
  smile(part_of(view, "Teeth").first_vertex + 1, 2) = 0.02f;  // node scale 2: 0.01 in the file
  rig.shapes.push_back(Blendshape::from_dense("mouthSmileLeft", smile));
  rig.shapes[0].deltas *= 2.0f;  // jawOpen changed
  write_back(doc, view, rig);
  const fs::path out = work_dir() / "written_back.glb";
  doc.write_glb(out);
  CHECK(validator_clean(out));

  const AvatarDocument again = AvatarDocument::read(out);
  const auto& m = again.model();
  CHECK(m.meshes[0].primitives[0].targets.size() == 3);
  CHECK(m.meshes[0].primitives[1].targets.size() == 3);
  CHECK(m.meshes[0].weights.size() == 3);
  CHECK(m.meshes[1].primitives[0].targets.size() == 2);
  CHECK(m.meshes[2].primitives[0].targets.empty());
  for (int i = 0; i < 2; ++i) CHECK(image_bytes(m, i) == test::test_avatar_png(i));
  const Rig back = make_view(again).rig;
  REQUIRE(sorted(back.shape_names()) ==
          std::vector<std::string>{"eyeBlinkLeft", "jawOpen", "mouthSmileLeft"});
  for (const auto& s : rig.shapes) {
    const auto& b = back.shapes[static_cast<std::size_t>(back.find_shape(s.name))];
    CHECK((b.dense(nv) - s.dense(nv)).cwiseAbs().maxCoeff() < 1e-6f);
  }
}

TEST_CASE("a required extension Facecast does not read is a one-line error naming it",
          "[rig][gltf][errors]") {
  AvatarDocument doc = AvatarDocument::parse(test::test_avatar_glb(), "base.glb");
  doc.model().extensionsRequired = {"KHR_materials_pbrSpecularGlossiness"};
  doc.model().extensionsUsed.push_back("KHR_materials_pbrSpecularGlossiness");
  try {
    (void)AvatarDocument::parse(doc.glb_bytes(), "upload.glb");
    FAIL("no error");
  } catch (const Error& e) {
    CHECK(std::string(e.what()) ==
          "upload.glb: required extension KHR_materials_pbrSpecularGlossiness is not supported");
    CHECK(e.code() == ErrorCode::kUnsupported);
  }
}

TEST_CASE("glb_bytes writes textures, PBR materials and the skeleton, one mesh per group",
          "[rig][gltf]") {
  const AvatarDocument doc = AvatarDocument::parse(test::test_avatar_glb(), "base.glb");
  const Rig rig = make_view(doc, {.all_meshes = true}).rig;
  const fs::path out = work_dir() / "exported.glb";
  write_file_atomic(out, glb_bytes(rig, GlbOptions{.mesh_per_group = true}));
  CHECK(validator_clean(out));
  const AvatarDocument again = AvatarDocument::read(out);
  CHECK(again.model().meshes.size() == 4);
  CHECK(again.model().skins.size() == 1);
  const Rig back = make_view(again, {.all_meshes = true}).rig;
  REQUIRE(back.vertex_count() == rig.vertex_count());
  CHECK((back.positions - rig.positions).cwiseAbs().maxCoeff() < 1e-5f);
  CHECK(back.groups == rig.groups);
  CHECK(back.shape_names() == rig.shape_names());
  for (const auto& s : rig.shapes) {
    const auto& b = back.shapes[static_cast<std::size_t>(back.find_shape(s.name))];
    CHECK((b.dense(rig.vertex_count()) - s.dense(rig.vertex_count())).cwiseAbs().maxCoeff() <
          1e-6f);
  }
  REQUIRE(back.textures.size() == 2);
  CHECK(back.textures[0].bytes == rig.textures[0].bytes);
  CHECK(back.textures[0].repeat_s == rig.textures[0].repeat_s);
  CHECK(back.materials[0].base_color_texture.offset.isApprox(
      rig.materials[0].base_color_texture.offset));
  CHECK(back.materials[0].normal_texture.strength == Approx(0.8f));
  CHECK(back.materials[3].alpha_mode == AlphaMode::kMask);
  CHECK(back.skeleton.joint_names == rig.skeleton.joint_names);
  CHECK(back.skeleton.parent == rig.skeleton.parent);
  CHECK(back.skeleton.head == rig.skeleton.head);
  CHECK((back.joint_weights - rig.joint_weights).cwiseAbs().maxCoeff() < 1e-6f);
  CHECK(back.joints == rig.joints);
}

TEST_CASE("a VRM 0.x figure, facing -Z in its file, is read facing +Z; shapes go back turned back",
          "[rig][gltf][vrm]") {
  const AvatarView plain = make_view(AvatarDocument::parse(test::test_avatar_glb(), "base.glb"));
  AvatarDocument doc = AvatarDocument::parse(test::test_avatar_glb(), "old.vrm");
  tinygltf::Value::Object vrm;
  vrm["specVersion"] = tinygltf::Value(std::string("0.0"));
  doc.model().extensions["VRM"] = tinygltf::Value(vrm);
  doc.model().extensionsUsed.push_back("VRM");
  const AvatarView view = make_view(doc);
  // The same file read as VRM 0.x is the figure turned half about +Y: x and z negated.
  const Eigen::DiagonalMatrix<float, 3> half(-1, 1, -1);
  const Positions turned = plain.rig.positions * half;
  CHECK((view.rig.positions - turned).cwiseAbs().maxCoeff() < 1e-5f);
  CHECK((view.rig.normals - plain.rig.normals * half).cwiseAbs().maxCoeff() < 1e-5f);
  REQUIRE(view.rig.skeleton.rest_origin.size() == plain.rig.skeleton.rest_origin.size());
  for (std::size_t j = 0; j < plain.rig.skeleton.rest_origin.size(); ++j)
    CHECK((view.rig.skeleton.rest_origin[j] - half * plain.rig.skeleton.rest_origin[j]).norm() <
          1e-5f);
  // A shape moving a vertex along +X in the rig is stored along -X in the file, and read back.
  Rig rig = view.rig;
  const int nv = rig.vertex_count();
  Positions smile = Positions::Zero(nv, 3);
  const int v = part_of(view, "Head").first_vertex + 3;
  smile(v, 0) = 0.01f;
  rig.shapes.push_back(Blendshape::from_dense("mouthSmileLeft", smile));
  write_back(doc, view, rig);
  const fs::path out = work_dir() / "old_written_back.vrm";
  doc.write_glb(out);
  const AvatarDocument again = AvatarDocument::read(out);
  const Rig back = make_view(again).rig;
  const auto& b = back.shapes[static_cast<std::size_t>(back.find_shape("mouthSmileLeft"))];
  CHECK((b.dense(nv) - smile).cwiseAbs().maxCoeff() < 1e-6f);
  // In the file's own axes (read without its VRM extension) the delta points along -X.
  AvatarDocument file = AvatarDocument::read(out);
  file.model().extensions.erase("VRM");
  std::erase(file.model().extensionsUsed, std::string("VRM"));
  const Rig unturned = make_view(file).rig;
  const auto& u = unturned.shapes[static_cast<std::size_t>(unturned.find_shape("mouthSmileLeft"))];
  CHECK(u.dense(nv)(v, 0) == Approx(-0.01f));
}
