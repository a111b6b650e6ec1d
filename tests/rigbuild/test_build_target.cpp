// A rig build into a user's avatar file: the default avatar as a skinned multi-mesh avatar with a
// body, its morph targets removed; the build from the default template writes the shapes back
// into its own face meshes and keeps everything else (Khronos validator clean).
#include <tiny_gltf.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "build_paths.hpp"
#include "facecast/avatar/avatar.hpp"
#include "facecast/core/files.hpp"
#include "facecast/rig/avatar_view.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/rigbuild/build.hpp"
#include "facecast/rigbuild/build_target.hpp"
#include "facecast/rigbuild/landmarks.hpp"
#include "facecast/rigbuild/template.hpp"
#include "stages.hpp"  // fit_sphere
#include "test_data.hpp"

namespace fs = std::filesystem;
using namespace facecast;
using facecast::rigbuild::load_shipped_template;

namespace {

fs::path out_dir() {
  const fs::path dir = facecast::test::build_dir() / "tests/rigbuild" / "build-target";
  fs::create_directories(dir);
  return dir;
}

int add_accessor(tinygltf::Model& m, const void* data, std::size_t bytes, int component, int type,
                 std::size_t count) {
  auto& buf = m.buffers[0].data;
  while (buf.size() % 4) buf.push_back(0);
  tinygltf::BufferView v;
  v.buffer = 0;
  v.byteOffset = buf.size();
  v.byteLength = bytes;
  const auto* p = static_cast<const unsigned char*>(data);
  buf.insert(buf.end(), p, p + bytes);
  m.bufferViews.push_back(v);
  tinygltf::Accessor a;
  a.bufferView = static_cast<int>(m.bufferViews.size()) - 1;
  a.componentType = component;
  a.type = type;
  a.count = count;
  m.accessors.push_back(a);
  return static_cast<int>(m.accessors.size()) - 1;
}

// Every vertex of `prim` bound to joint `joint` alone.
void bind(tinygltf::Model& m, tinygltf::Primitive& prim, std::uint16_t joint) {
  const std::size_t n = m.accessors[static_cast<std::size_t>(prim.attributes.at("POSITION"))].count;
  std::vector<std::uint16_t> j(n * 4, 0);
  std::vector<float> w(n * 4, 0.0f);
  for (std::size_t v = 0; v < n; ++v) j[v * 4] = joint, w[v * 4] = 1.0f;
  prim.attributes["JOINTS_0"] = add_accessor(
      m, j.data(), j.size() * 2, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_TYPE_VEC4, n);
  prim.attributes["WEIGHTS_0"] =
      add_accessor(m, w.data(), w.size() * 4, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC4, n);
}

// The default avatar's GLB with its morph targets removed, a skeleton (Hips > Neck > Head) that
// carries the face meshes by the head, and a body box under them bound to the hips.
std::string avatar_without_shapes() {
  rig::AvatarDocument doc =
      rig::AvatarDocument::parse(rig::glb_bytes(avatar::default_avatar()), "avatar.glb");
  tinygltf::Model& m = doc.model();
  for (auto& mesh : m.meshes) {
    for (auto& p : mesh.primitives) p.targets.clear();
    mesh.weights.clear();
    mesh.extras = tinygltf::Value();
  }
  const std::vector<int> face_nodes = m.scenes[0].nodes;
  // Joints at their rest places; inverse bind matrices undo them.
  const float at[3][3] = {{0, -8, 0}, {0, 4, 0}, {0, 2, 0}};  // local translations
  const char* names[3] = {"Hips", "Neck", "Head"};
  std::vector<float> ibm;
  float world_y = 0;
  const int first = static_cast<int>(m.nodes.size());
  for (int k = 0; k < 3; ++k) {
    tinygltf::Node n;
    n.name = names[k];
    n.translation = {at[k][0], at[k][1], at[k][2]};
    if (k < 2) n.children = {first + k + 1};
    m.nodes.push_back(n);
    world_y += at[k][1];
    const float inv[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -world_y, 0, 1};
    ibm.insert(ibm.end(), inv, inv + 16);
  }
  tinygltf::Skin skin;
  skin.joints = {first, first + 1, first + 2};
  skin.inverseBindMatrices = add_accessor(m, ibm.data(), ibm.size() * 4,
                                          TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_MAT4, 3);
  m.skins.push_back(skin);
  for (const int n : face_nodes) {
    m.nodes[static_cast<std::size_t>(n)].skin = 0;
    for (auto& p :
         m.meshes[static_cast<std::size_t>(m.nodes[static_cast<std::size_t>(n)].mesh)].primitives)
      bind(m, p, 2);
  }
  // The body: a box below the head, bound to the hips.
  const float box[8][3] = {{-5, -16, -3}, {5, -16, -3}, {5, -9, -3}, {-5, -9, -3},
                           {-5, -16, 3},  {5, -16, 3},  {5, -9, 3},  {-5, -9, 3}};
  const std::uint32_t faces[36] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                   3, 7, 6, 3, 6, 2, 0, 4, 7, 0, 7, 3, 1, 2, 6, 1, 6, 5};
  tinygltf::Primitive body;
  body.attributes["POSITION"] =
      add_accessor(m, box, sizeof box, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, 8);
  m.accessors.back().minValues = {-5, -16, -3};
  m.accessors.back().maxValues = {5, -9, 3};
  body.indices = add_accessor(m, faces, sizeof faces, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT,
                              TINYGLTF_TYPE_SCALAR, 36);
  tinygltf::Material plain;
  plain.name = "M_Body";
  m.materials.push_back(plain);
  body.material = static_cast<int>(m.materials.size()) - 1;
  body.mode = TINYGLTF_MODE_TRIANGLES;
  bind(m, body, 0);
  tinygltf::Mesh body_mesh;
  body_mesh.name = "Body";
  body_mesh.primitives.push_back(body);
  m.meshes.push_back(body_mesh);
  tinygltf::Node body_node;
  body_node.name = "Body";
  body_node.mesh = static_cast<int>(m.meshes.size()) - 1;
  body_node.skin = 0;
  m.nodes.push_back(body_node);
  m.scenes[0].nodes.push_back(first);
  m.scenes[0].nodes.push_back(static_cast<int>(m.nodes.size()) - 1);
  return doc.glb_bytes();
}

bool validator_clean(const fs::path& path) {
  const std::string cmd = "node " + facecast::test::source_dir().string() +
                          "/scripts/validate-gltf.mjs '" + path.string() + "' > '" + path.string() +
                          ".validation' 2>&1";
  const int rc = std::system(cmd.c_str());
  if (rc != 0) UNSCOPED_INFO(read_file(path.string() + ".validation"));
  return rc == 0;
}

// |a - b| / |b| over all vertices.
double relative_difference(const rig::Rig& a, const rig::Rig& b, const std::string& shape) {
  const int sa = a.find_shape(shape), sb = b.find_shape(shape);
  REQUIRE(sa >= 0);
  REQUIRE(sb >= 0);
  const rig::Positions da = a.shapes[static_cast<std::size_t>(sa)].dense(a.vertex_count());
  const rig::Positions db = b.shapes[static_cast<std::size_t>(sb)].dense(b.vertex_count());
  return (da - db).norm() / db.norm();
}

// `out` (the build written into `in`) keeps `in`'s nodes, skin, materials and images byte for
// byte; the body gets no targets, the head many.
void check_kept(const fs::path& in, const fs::path& out) {
  const auto before = rig::AvatarDocument::read(in);
  const auto after = rig::AvatarDocument::read(out);
  const tinygltf::Model &a = before.model(), &b = after.model();
  REQUIRE(a.meshes.size() == b.meshes.size());
  CHECK(a.nodes.size() == b.nodes.size());
  CHECK(a.skins.size() == b.skins.size());
  CHECK(b.skins[0].joints == a.skins[0].joints);
  CHECK(a.materials.size() == b.materials.size());
  REQUIRE(a.images.size() == b.images.size());
  for (std::size_t i = 0; i < a.images.size(); ++i) {
    const auto bytes = [](const tinygltf::Model& m, std::size_t k) {
      const auto& v = m.bufferViews[static_cast<std::size_t>(m.images[k].bufferView)];
      const auto& d = m.buffers[static_cast<std::size_t>(v.buffer)].data;
      return std::string(reinterpret_cast<const char*>(d.data() + v.byteOffset), v.byteLength);
    };
    CHECK(bytes(a, i) == bytes(b, i));
  }
  for (const auto& mesh : b.meshes) {
    INFO(mesh.name);
    if (mesh.name == "Body")
      CHECK(mesh.primitives[0].targets.empty());  // the template moves nothing there
    else if (mesh.name == "Head")
      CHECK(mesh.primitives[0].targets.size() >= 40);
  }
}

}  // namespace

TEST_CASE("a build into an avatar file writes the shapes into its face meshes and keeps the rest",
          "[rigbuild][avatar]") {
  const fs::path in = out_dir() / "no-shapes.glb", out = out_dir() / "rebuilt.glb";
  write_file_atomic(in, avatar_without_shapes());
  const rig::Rig& tmpl = avatar::default_avatar();

  const rigbuild::BuildTarget target = rigbuild::BuildTarget::read(in);
  REQUIRE(target.is_avatar());
  // The face is what the head joint carries: the five face meshes, not the body.
  CHECK(target.neutral().vertex_count() == tmpl.vertex_count());
  CHECK(target.neutral().shapes.empty());

  const auto r = rigbuild::build_rig(tmpl, target.neutral(), rigbuild::load_build_options());
  write_file_atomic(out, target.glb_bytes(r.rig));
  CHECK(validator_clean(out));

  check_kept(in, out);

  // Same topology as the template: the shapes come back as the template's.
  const auto after = rig::AvatarDocument::read(out);
  const rig::AvatarView view = rig::make_view(after);
  CHECK(view.rig.vertex_count() == tmpl.vertex_count());
  for (const char* shape : {"jawOpen", "eyeBlinkLeft", "mouthSmileLeft", "eyeLookInLeft"}) {
    INFO(shape);
    CHECK(relative_difference(view.rig, tmpl, shape) < 0.05);
  }
}

namespace {

// The lid gap of the eye whose corners are landmarks `inner` and `outer` of `rig`'s 68, under
// `delta` (a shape at full weight): the vertices of every mesh but the eyeballs ("Eye*" in the
// default avatar's mesh layout, which `rig` shares; lids and lashes are parts of their own there)
// in a column through the eye's centre (|x - cx| <
// 15 % of the eye's width, |y - cy| < 60 %, in front of the corners' depth less 30 %), split by the
// neutral into above and below the centre; the gap is the lowest of those above minus the highest
// of those below.
double lid_gap(const rig::Rig& rig, const std::array<int, 68>& lm, int inner, int outer,
               const rig::Positions& delta) {
  const Eigen::RowVector3f a = rig.positions.row(lm[static_cast<std::size_t>(inner)]);
  const Eigen::RowVector3f b = rig.positions.row(lm[static_cast<std::size_t>(outer)]);
  const Eigen::RowVector3f c = 0.5f * (a + b);
  const float w = (a - b).norm();
  const rig::Rig& layout = avatar::default_avatar();
  REQUIRE(layout.vertex_count() == rig.vertex_count());
  REQUIRE(!layout.meshes.empty());
  float upper = 1e9f, lower = -1e9f;
  for (int v = 0; v < rig.vertex_count(); ++v) {
    const Eigen::RowVector3f p = rig.positions.row(v);
    if (layout.meshes[static_cast<std::size_t>(layout.mesh_of(v))].name.starts_with("Eye"))
      continue;
    if (std::abs(p.x() - c.x()) > 0.15f * w || std::abs(p.y() - c.y()) > 0.6f * w ||
        p.z() < c.z() - 0.3f * w)
      continue;
    const float y = p.y() + delta(v, 1);
    if (p.y() > c.y())
      upper = std::min(upper, y);
    else
      lower = std::max(lower, y);
  }
  return upper - lower;
}

}  // namespace

TEST_CASE("an avatar of another topology gets the shipped template's shapes with no markers",
          "[rigbuild][avatar][template][slow]") {
  if (!test::require_data(test::ict_dir() / "generic_neutral_mesh.obj")) return;  // packed from it
  const fs::path in = out_dir() / "no-shapes-ict.glb", out = out_dir() / "rebuilt-ict.glb";
  write_file_atomic(in, avatar_without_shapes());
  const rig::Rig tmpl = load_shipped_template();
  const rigbuild::BuildTarget target = rigbuild::BuildTarget::read(in);
  const rig::Rig& head = target.neutral();
  REQUIRE(head.vertex_count() != tmpl.vertex_count());

  const auto r = rigbuild::build_rig(tmpl, head, rigbuild::load_build_options());
  REQUIRE(r.landmarks);  // found automatically
  write_file_atomic(out, target.glb_bytes(r.rig));
  CHECK(validator_clean(out));
  check_kept(in, out);
  const auto after = rig::AvatarDocument::read(out);
  // Every mesh in node order: the five face meshes, then the body's 8 vertices.
  rig::Rig built = rig::make_view(after, {.all_meshes = true}).rig;
  REQUIRE(built.vertex_count() == head.vertex_count() + 8);
  built.positions.conservativeResize(head.vertex_count(), 3);
  for (auto& s : built.shapes) {
    const auto body = std::find_if(s.vertices.begin(), s.vertices.end(),
                                   [&](int v) { return v >= head.vertex_count(); });
    CHECK(body == s.vertices.end());
  }
  CHECK((built.positions - head.positions).cwiseAbs().maxCoeff() < 1e-5f);  // the mesh kept
  for (const char* v : {"viseme_aa", "viseme_PP", "browInnerUp", "eyeBlinkRight"})
    CHECK(built.find_shape(v) >= 0);

  // The head's own 68 landmarks (stored for the default avatar; its dropped lid midpoints are
  // not needed: corners 36/39 and 42/45, inner lips 62/66).
  const auto lm = rigbuild::known_landmarks(avatar::default_avatar());
  REQUIRE(lm);
  const auto dense = [&](const char* name) {
    const int s = built.find_shape(name);
    REQUIRE(s >= 0);
    return built.shapes[static_cast<std::size_t>(s)].dense(built.vertex_count());
  };
  const rig::Positions still = rig::Positions::Zero(built.vertex_count(), 3);
  const double iod = (head.positions.row((*lm)[36]) - head.positions.row((*lm)[45])).norm();
  // jawOpen parts the inner lips by a good part of the eyes' distance.
  const rig::Positions jaw = dense("jawOpen");
  const auto lip_gap = [&](const rig::Positions& d) {
    return (head.positions.row((*lm)[62]) + d.row((*lm)[62]) - head.positions.row((*lm)[66]) -
            d.row((*lm)[66]))
        .norm();
  };
  const double opened = lip_gap(jaw) - lip_gap(still);
  // Blinks: the subject's left eye is landmarks 42-47 (+x), the right 36-41.
  const double left_open = lid_gap(head, *lm, 42, 45, still);
  const double right_open = lid_gap(head, *lm, 39, 36, still);
  const double left_closed = 1.0 - lid_gap(head, *lm, 42, 45, dense("eyeBlinkLeft")) / left_open;
  const double right_closed = 1.0 - lid_gap(head, *lm, 39, 36, dense("eyeBlinkRight")) / right_open;
  const double left_other = 1.0 - lid_gap(head, *lm, 42, 45, dense("eyeBlinkRight")) / left_open;
  // The measure on the head's own (the default avatar's) blinks, for comparison.
  const rig::Rig& own = avatar::default_avatar();
  const auto own_dense = [&](const char* name) {
    return own.shapes[static_cast<std::size_t>(own.find_shape(name))].dense(own.vertex_count());
  };
  const double own_left = 1.0 - lid_gap(own, *lm, 42, 45, own_dense("eyeBlinkLeft")) / left_open;
  WARN("ICT template -> default avatar without markers: jawOpen parts the lips by "
       << opened / iod << " x the eyes' distance; eyeBlinkLeft closes " << 100 * left_closed
       << " % of the lid gap, eyeBlinkRight " << 100 * right_closed
       << " % (the avatar's own eyeBlinkLeft: " << 100 * own_left << " %); build "
       << r.timings.total << " s (landmarks " << r.timings.landmarks << " s)");
  CHECK(left_open > 0);
  CHECK(right_open > 0);
  CHECK(own_left >= 0.8);  // the measure sees a closed lid
  CHECK(opened > 0.25 * iod);
  // The blinks move the right lids down, each its own eye...
  CHECK(left_closed > 0.15);
  CHECK(right_closed > 0.15);
  CHECK(left_other < 0.5 * left_closed);
  // The eyeballs (separate meshes) turn with the template's eyes about their own centres, each
  // with its own eyeLook shapes; the lower teeth and the tongue follow the jaw.
  const rig::Rig& layout = avatar::default_avatar();
  const auto members = [&](auto&& keep) {
    std::vector<int> kept;
    for (int v = 0; v < head.vertex_count(); ++v)
      if (keep(layout.meshes[static_cast<std::size_t>(layout.mesh_of(v))].name, v))
        kept.push_back(v);
    return kept;
  };
  std::vector<int> eye_pos = members([](const std::string& m, int) { return m == "EyeLeft"; });
  std::vector<int> eye_neg = members([](const std::string& m, int) { return m == "EyeRight"; });
  REQUIRE(!eye_pos.empty());
  REQUIRE(!eye_neg.empty());
  if (head.positions(eye_pos[0], 0) < 0) std::swap(eye_pos, eye_neg);  // +x: the subject's left
  const auto turn = [&](const std::vector<int>& eye, const rig::Positions& d) {
    rigbuild::Points at(static_cast<Eigen::Index>(eye.size()), 3);
    for (std::size_t i = 0; i < eye.size(); ++i)
      at.row(static_cast<Eigen::Index>(i)) = head.positions.row(eye[i]).cast<double>();
    const rigbuild::Sphere ball = rigbuild::fit_sphere(at);
    int front = eye[0];  // the pupil: the vertex furthest forward
    double radial = 0;   // the largest change of a vertex's distance from the centre
    for (int v : eye) {
      if (head.positions(v, 2) > head.positions(front, 2)) front = v;
      const Eigen::RowVector3d p = head.positions.row(v).cast<double>();
      radial = std::max(radial, std::abs((p + d.row(v).cast<double>() - ball.centre).norm() -
                                         (p - ball.centre).norm()));
    }
    CHECK(radial < 1e-3 * ball.radius);  // a rotation about the centre
    return Eigen::RowVector3d(d.row(front).cast<double>() / ball.radius);
  };
  const Eigen::RowVector3d in_left = turn(eye_pos, dense("eyeLookInLeft"));
  const Eigen::RowVector3d out_left = turn(eye_pos, dense("eyeLookOutLeft"));
  const Eigen::RowVector3d up_right = turn(eye_neg, dense("eyeLookUpRight"));
  const Eigen::RowVector3d in_left_other = turn(eye_neg, dense("eyeLookInLeft"));
  WARN("pupil moves / eyeball radius: eyeLookInLeft " << in_left << ", eyeLookOutLeft " << out_left
                                                      << ", eyeLookUpRight " << up_right);
  CHECK(in_left.x() < -0.1);  // towards the nose: the left eye's -x
  CHECK(out_left.x() > 0.1);
  CHECK(up_right.y() > 0.1);
  CHECK(in_left_other.norm() < 1e-6);
  // The teeth mesh's two rows: the lower (smaller y) opens with the jaw, the upper stays.
  std::vector<int> teeth = members([](const std::string& m, int) { return m == "Teeth"; });
  const rig::Components rows = rig::connected_components(head.vertex_count(), head.triangles);
  double mean_y[2] = {0, 0}, moved_y[2] = {0, 0};
  int count[2] = {0, 0}, first_row = rows.label[static_cast<std::size_t>(teeth[0])];
  for (int v : teeth) {
    const int row = rows.label[static_cast<std::size_t>(v)] == first_row ? 0 : 1;
    mean_y[row] += head.positions(v, 1), moved_y[row] += jaw(v, 1), ++count[row];
  }
  REQUIRE(count[1] > 0);
  const int lower = mean_y[0] / count[0] < mean_y[1] / count[1] ? 0 : 1;
  CHECK(moved_y[lower] / count[lower] < -0.1 * iod);
  CHECK(std::abs(moved_y[1 - lower] / count[1 - lower]) < 0.02 * iod);
  double tongue_y = 0;
  const std::vector<int> tongue = members([](const std::string& m, int) { return m == "Tongue"; });
  for (int v : tongue) tongue_y += jaw(v, 1);
  CHECK(tongue_y / static_cast<double>(tongue.size()) < -0.05 * iod);

  // ... and close them: the gap closes by at least 80 % of the open gap, and the upper lid ends
  // less than 60 % of that gap past the lower one. On this measure a closed lid reads over 100 %
  // (the closing upper lid's front passes in front of the lower lid: the avatar's own blink reads
  // 127 %); measured 148 % left, 131 % right. The two eyes alike within a quarter.
  CHECK(left_closed >= 0.8);
  CHECK(right_closed >= 0.8);
  CHECK(left_closed <= 1.6);
  CHECK(right_closed <= 1.6);
  CHECK(std::min(left_closed, right_closed) >= 0.75 * std::max(left_closed, right_closed));
}
