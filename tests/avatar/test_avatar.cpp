// The built-in avatar: determinism, size, names, topology, rigid parts, lids, variants, and the
// self-intersection check of the neutral, every shape and the pairs that animate together.
#include <catch2/catch.hpp>
#include <cmath>
#include <map>
#include <set>

#include "facecast/avatar/avatar.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/error.hpp"
#include "facecast/rig/intersections.hpp"
#include "facecast/rig/rig_io.hpp"

using namespace facecast;
using namespace facecast::rig;
using namespace facecast::avatar;

namespace {

Positions pose(const Rig& rig, const std::vector<std::pair<std::string, float>>& weights) {
  Positions p = rig.positions;
  for (const auto& [name, w] : weights) {
    const int s = rig.find_shape(name);
    REQUIRE(s >= 0);
    const auto& sh = rig.shapes[static_cast<std::size_t>(s)];
    for (std::size_t i = 0; i < sh.vertices.size(); ++i)
      p.row(sh.vertices[i]) += w * sh.deltas.row(static_cast<Eigen::Index>(i));
  }
  return p;
}

std::vector<int> vertices_in(const Rig& rig, const std::string& group) {
  const int g =
      static_cast<int>(std::find(rig.groups.begin(), rig.groups.end(), group) - rig.groups.begin());
  std::set<int> v;
  for (int f = 0; f < rig.triangle_count(); ++f)
    if (rig.triangle_group[static_cast<std::size_t>(f)] == g)
      for (int c = 0; c < 3; ++c) v.insert(rig.triangles(f, c));
  return {v.begin(), v.end()};
}

// Largest change of pairwise distance among a sample of the vertices (0 for a rigid motion).
float rigidity_error(const Positions& a, const Positions& b, const std::vector<int>& vs) {
  float worst = 0;
  for (std::size_t i = 0; i < vs.size(); i += 7)
    for (std::size_t j = i + 3; j < vs.size(); j += 11) {
      const float da = (a.row(vs[i]) - a.row(vs[j])).norm(),
                  db = (b.row(vs[i]) - b.row(vs[j])).norm();
      worst = std::max(worst, std::abs(da - db));
    }
  return worst;
}

std::size_t intersections(const Rig& rig, const Positions& p) {
  IntersectionOptions opt;
  opt.ignore = ignore_between_groups(rig, {{"lip_upper", "lip_lower"}});
  return find_intersections(p, rig.triangles, opt).count;
}

}  // namespace

TEST_CASE("the avatar is deterministic and the right size", "[avatar]") {
  // Its generation time is a figure of bench_render, not a check here (the machine is shared).
  const std::string a = glb_bytes(make_avatar());
  const std::string b = glb_bytes(make_avatar());
  CHECK(a == b);
  const Rig& rig = default_avatar();
  CHECK(rig.vertex_count() >= 10000);
  CHECK(rig.vertex_count() <= 30000);
  CHECK(rig.shape_names() == avatar_shape_names());
  CHECK(rig.shapes.size() == 52);
  for (const auto& s : rig.shapes) CHECK(s.max_displacement() > 0.05f);
  // Distinct colours for the named parts.
  std::set<std::string> names;
  for (const auto& m : rig.materials) names.insert(m.name);
  for (const char* n : {"M_Skin", "M_Lips", "M_Teeth", "M_Tongue", "M_Sclera", "M_Iris", "M_Pupil",
                        "M_MouthInterior"})
    CHECK(names.count(n));
  for (std::size_t i = 0; i < rig.materials.size(); ++i)
    for (std::size_t j = i + 1; j < rig.materials.size(); ++j) {
      const auto& m1 = rig.materials[i];
      const auto& m2 = rig.materials[j];
      CHECK(((m1.base_color - m2.base_color).norm() > 0.02f ||
             m1.base_color_texture.texture != m2.base_color_texture.texture));
    }
  // The skin (with its brows and blush) and the irises are textured: PNGs sampled through UVs.
  REQUIRE(rig.textures.size() == 2);
  for (const auto& t : rig.textures) CHECK(t.bytes.rfind("\x89PNG\r\n\x1a\n", 0) == 0);
  CHECK(rig.uvs.rows() == rig.vertex_count());
  CHECK(rig.uvs.minCoeff() >= 0.0f);
  CHECK(rig.uvs.maxCoeff() <= 1.0f);
  for (const auto& m : rig.materials)
    if (m.name == "M_Skin" || m.name == "M_Iris") CHECK(m.base_color_texture.texture >= 0);
  // Skin, two teeth rows, tongue, two eyeballs, four lids.
  CHECK(connected_components(rig.vertex_count(), rig.triangles).count == 10);
  // The GLB round trip keeps everything the server needs.
  const Rig back = parse_glb(a, "avatar.glb");
  CHECK(back.vertex_count() == rig.vertex_count());
  CHECK(back.shape_names() == rig.shape_names());
}

TEST_CASE("the avatar's skin is one closed surface and the lips meet", "[avatar]") {
  const Rig& rig = default_avatar();
  std::set<int> skin_groups;
  for (const char* g : {"skin", "lip_upper", "lip_lower"})
    skin_groups.insert(
        static_cast<int>(std::find(rig.groups.begin(), rig.groups.end(), g) - rig.groups.begin()));
  std::map<std::pair<int, int>, int> edges;
  for (int f = 0; f < rig.triangle_count(); ++f) {
    if (!skin_groups.count(rig.triangle_group[static_cast<std::size_t>(f)])) continue;
    for (int c = 0; c < 3; ++c) {
      int a = rig.triangles(f, c), b = rig.triangles(f, (c + 1) % 3);
      ++edges[{std::min(a, b), std::max(a, b)}];
    }
  }
  std::size_t bad = 0;
  for (const auto& [e, n] : edges) bad += n != 2;
  CHECK(bad == 0);
  // Upper and lower lips: closest points of the two lip bands are nearly touching.
  const auto up = vertices_in(rig, "lip_upper"), low = vertices_in(rig, "lip_lower");
  const auto corner = std::find_if(rig.landmarks.begin(), rig.landmarks.end(),
                                   [](const Landmark& l) { return l.name == "upper_lip_center"; });
  REQUIRE(corner != rig.landmarks.end());
  float gap = 1e9f;
  for (int u : up)
    for (int l : low)
      if (std::abs(rig.positions(u, 0)) < 0.3f && std::abs(rig.positions(l, 0)) < 0.3f)
        gap = std::min(gap, (rig.positions.row(u) - rig.positions.row(l)).norm());
  CHECK(gap < 0.05f);
  CHECK(gap > 0.0f);
}

TEST_CASE("teeth and tongue follow the jaw, eyeballs rotate, lids stay outside the eyeball",
          "[avatar]") {
  const Rig& rig = default_avatar();
  const Positions open = pose(rig, {{"jawOpen", 1.0f}});
  const auto lower = vertices_in(rig, "teeth_lower"), upper = vertices_in(rig, "teeth_upper");
  const auto tongue = vertices_in(rig, "tongue");
  CHECK(rigidity_error(rig.positions, open, lower) < 1e-3f);
  CHECK(rigidity_error(rig.positions, open, tongue) < 1e-3f);
  CHECK((open(lower[0], 1) - rig.positions(lower[0], 1)) < -0.5f);  // the lower teeth went down
  for (int v : upper) CHECK(open.row(v) == rig.positions.row(v));
  // The mouth opens: lip centres move apart by more than 1.5 cm.
  const auto lm = [&](const char* n) {
    return std::find_if(rig.landmarks.begin(), rig.landmarks.end(),
                        [&](const Landmark& l) { return l.name == n; })
        ->vertex;
  };
  const float closed =
      (rig.positions.row(lm("upper_lip_center")) - rig.positions.row(lm("lower_lip_center")))
          .norm();
  const float opened = (open.row(lm("upper_lip_center")) - open.row(lm("lower_lip_center"))).norm();
  CHECK(opened - closed > 1.5f);

  const auto eye = vertices_in(rig, "eyeball_left");
  const Positions look = pose(rig, {{"eyeLookUpLeft", 1.0f}});
  CHECK(rigidity_error(rig.positions, look, eye) < 1e-3f);
  const int pupil = lm("pupil_left");
  CHECK(look(pupil, 1) > rig.positions(pupil, 1) + 0.3f);

  // Eye centre and radius from the eyeball's vertices.
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e9f), hi = -lo;
  for (int v : eye) {
    lo = lo.cwiseMin(rig.positions.row(v).transpose());
    hi = hi.cwiseMax(rig.positions.row(v).transpose());
  }
  const Eigen::Vector3f c = 0.5f * (lo + hi);
  float radius = 0;
  for (int v : eye) radius = std::max(radius, (rig.positions.row(v).transpose() - c).norm());
  const auto lids_up = vertices_in(rig, "lid_upper_left"),
             lids_low = vertices_in(rig, "lid_lower_left");
  for (float w : {0.25f, 0.5f, 0.75f, 1.0f}) {
    const Positions blink = pose(rig, {{"eyeBlinkLeft", w}});
    for (const auto* lid : {&lids_up, &lids_low})
      for (int v : *lid) REQUIRE((blink.row(v).transpose() - c).norm() > radius + 0.02f);
  }
  // Closed: in front of the eye, the upper lid reaches below the lower lid's highest point.
  const Positions shut = pose(rig, {{"eyeBlinkLeft", 1.0f}});
  float upper_low = 1e9f, lower_high = -1e9f;
  for (int v : lids_up)
    if (std::abs(shut(v, 0) - c.x()) < 0.3f && shut(v, 2) > c.z())
      upper_low = std::min(upper_low, shut(v, 1));
  for (int v : lids_low)
    if (std::abs(shut(v, 0) - c.x()) < 0.3f && shut(v, 2) > c.z())
      lower_high = std::max(lower_high, shut(v, 1));
  CHECK(upper_low < lower_high);
}

TEST_CASE("variants are other users with the same topology", "[avatar]") {
  CHECK(avatar_variant(0).face_width == AvatarParams{}.face_width);
  const AvatarParams p = avatar_variant(7);
  CHECK(avatar_variant(7).jaw_length == p.jaw_length);
  CHECK_NOTHROW(p.validate());
  const Rig other = make_avatar(p);
  const Rig& base = default_avatar();
  CHECK(other.vertex_count() == base.vertex_count());
  CHECK(other.triangles == base.triangles);
  CHECK((other.positions - base.positions).cwiseAbs().maxCoeff() > 0.2f);
  CHECK(intersections(other, other.positions) == 0);
  AvatarParams bad;
  bad.eye_size = 2.0f;
  CHECK_THROWS_AS(make_avatar(bad), Error);
}

TEST_CASE("the avatar defaults match configs/avatar/avatar.json", "[avatar]") {
  const auto j = load_json(config_path("avatar/avatar.json"));
  const AvatarParams d;
  CHECK(j.at("params").at("face_width").get<float>() == d.face_width);
  CHECK(j.at("params").at("jaw_length").get<float>() == d.jaw_length);
  CHECK(j.at("params").at("lip_thickness").get<float>() == d.lip_thickness);
  CHECK(j.at("params").at("eye_size").get<float>() == d.eye_size);
  CHECK(j.at("params").at("nose_length").get<float>() == d.nose_length);
}

TEST_CASE("no self-intersections in the neutral and the animated pairs", "[avatar]") {
  const Rig& rig = default_avatar();
  CHECK(intersections(rig, rig.positions) == 0);
  for (const auto& [a, b] :
       std::vector<std::pair<std::string, std::string>>{{"jawOpen", "mouthClose"},
                                                        {"jawOpen", "mouthSmileLeft"},
                                                        {"jawOpen", "mouthSmileRight"},
                                                        {"eyeBlinkLeft", "eyeLookDownLeft"},
                                                        {"eyeBlinkRight", "eyeLookDownRight"}}) {
    INFO(a << " + " << b);
    CHECK(intersections(rig, pose(rig, {{a, 1.0f}, {b, 1.0f}})) == 0);
  }
}

TEST_CASE("no self-intersections in any shape at weight 1", "[avatar][slow]") {
  // mouthClose is defined relative to an open jaw (as in ARKit) and is checked with jawOpen above.
  const Rig& rig = default_avatar();
  for (const auto& s : rig.shapes) {
    if (s.name == "mouthClose") continue;
    INFO(s.name);
    CHECK(intersections(rig, pose(rig, {{s.name, 1.0f}})) == 0);
  }
}
