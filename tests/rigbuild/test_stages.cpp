// The rig builder's stages and geometry toolbox on small inputs (no shared data needed).
#include <Eigen/Geometry>
#include <atomic>
#include <catch2/catch.hpp>
#include <cmath>

#include "facecast/core/error.hpp"
#include "facecast/rigbuild/correspondence.hpp"
#include "facecast/rigbuild/geometry.hpp"
#include "facecast/rigbuild/landmarks.hpp"
#include "stages.hpp"  // private to rigbuild: the stages of build_rig

using namespace facecast;
using namespace facecast::rigbuild;

namespace {

// Two unit squares of two triangles each, apart: a "skin" (vertices 0-3, with a ring of two
// more triangles so it is the larger part) and a "tooth" (vertices 6-9).
rig::Rig skin_and_tooth() {
  rig::Rig r;
  r.positions.resize(10, 3);
  r.positions << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 2, 0, 0, 2, 1, 0,  //
      0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1;
  r.triangles.resize(6, 3);
  r.triangles << 0, 1, 2, 0, 2, 3, 1, 4, 5, 1, 5, 2, 6, 7, 8, 6, 8, 9;
  r.triangle_material.assign(6, 0);
  r.materials.push_back({});
  r.normals = rig::vertex_normals(r.positions, r.triangles);
  return r;
}

}  // namespace

TEST_CASE("procrustes finds the rigid motion and the similarity", "[rigbuild][geometry]") {
  Points from(5, 3);
  from << 0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 3, 1, 1, 1;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).matrix();
  const Eigen::Vector3d t(0.5, -1, 2);
  Similarity truth;
  truth.R = R;
  truth.t = t;
  const Similarity rigid = procrustes(from, truth.apply(from), false);
  CHECK((rigid.R - R).norm() < 1e-12);
  CHECK((rigid.t - t).norm() < 1e-12);
  CHECK(rigid.scale == 1.0);
  CHECK(rigid.rms < 1e-12);
  truth.scale = 2.5;
  const Similarity scaled = procrustes(from, truth.apply(from), true);
  CHECK(scaled.scale == Approx(2.5));
  CHECK((scaled.R - R).norm() < 1e-12);
  CHECK(scaled.rms < 1e-12);
  // Without scale the best rigid motion leaves a residual.
  CHECK(procrustes(from, truth.apply(from), false).rms > 0.1);
}

TEST_CASE("a sphere fit finds an eyeball's centre and radius", "[rigbuild][geometry]") {
  // Points on part of a sphere (an eyeball's visible cap) and a few off it by 2 % of the radius.
  const Eigen::RowVector3d centre(0.3, -1.2, 4.0);
  const double radius = 1.7;
  Points p(60, 3);
  for (int i = 0; i < 60; ++i) {
    const double a = 0.1 * i, b = 0.05 * (i % 13);
    const double r = radius * (i % 7 == 0 ? 1.02 : 1.0);
    p.row(i) = centre + r * Eigen::RowVector3d(std::cos(a) * std::sin(b + 0.3),
                                               std::sin(a) * std::sin(b + 0.3), std::cos(b + 0.3));
  }
  const Sphere s = fit_sphere(p);
  CHECK((s.centre - centre).norm() < 0.02 * radius);
  CHECK(std::abs(s.radius - radius) < 0.02 * radius);
  CHECK(s.rms < 0.01 * radius);
  CHECK(s.rms > 0.0);
}

TEST_CASE("the triangle-order matcher pairs equal triangles once each", "[rigbuild][geometry]") {
  Triangles a(3, 3), b(3, 3);
  a << 0, 1, 2, 0, 1, 2, 2, 3, 1;  // a triangle twice
  b << 1, 2, 0, 3, 1, 2, 2, 0, 1;  // rotated corners, another order
  const auto order = match_triangle_order(a, b);
  REQUIRE(order.has_value());
  CHECK(*order == std::vector<int>{0, 2, 1});
  b.row(1) << 1, 2, 0;  // the template's duplicate three times: one too many
  CHECK(!match_triangle_order(a, b).has_value());

  rig::Rig tmpl = skin_and_tooth(), target = tmpl;
  target.triangles.row(0).swap(target.triangles.row(5));
  target.triangle_material = {5, 1, 2, 3, 4, 0};
  target.triangle_group = {5, 1, 2, 3, 4, 0};
  REQUIRE(reorder_triangles_like(tmpl, target));
  CHECK(target.triangles == tmpl.triangles);
  CHECK(target.triangle_material == std::vector<int>{0, 1, 2, 3, 4, 5});
  CHECK(target.triangle_group == std::vector<int>{0, 1, 2, 3, 4, 5});
}

TEST_CASE("markers parsed from JSON name the value and the pair in errors", "[rigbuild][errors]") {
  const auto message = [](const nlohmann::json& j) {
    try {
      parse_markers(j, 10, 5);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const nlohmann::json pairs = {{"template", 1}, {"target", 1}};
  CHECK(message({{"index_base", 1},
                 {"pairs", {pairs, pairs, {{"name", "nose"}, {"template", 2}, {"target", 6}}}}}) ==
        "markers: pairs[2] (nose): target vertex 6 out of range (5 vertices)");
  CHECK(message({{"pairs", {pairs}}}) == "markers: at least 3 marker pairs are needed");
  CHECK(message({{"pairs", 3}}) == "markers: expected an object with a \"pairs\" array");
  const auto ok = parse_markers({{"index_base", 1}, {"pairs", {pairs, pairs, pairs}}}, 10, 5);
  REQUIRE(ok.size() == 3);
  CHECK(ok[2].template_vertex == 0);
  CHECK(ok[2].name == "pair2");
}

TEST_CASE("connected components given for another mesh are rejected naming the input",
          "[rigbuild][errors]") {
  const rig::Rig r = skin_and_tooth();
  const Points rest = r.positions.cast<double>();
  const rig::Components own = rig::connected_components(10, r.triangles);
  rig::Components other;
  other.label.assign(5, 0);
  CHECK_THROWS_WITH(compute_correspondence(rest, r.triangles, own, {}, rest, r.triangles, other, {},
                                           RegistrationOptions{}),
                    "correspondence: target components: 5 vertex labels for 10 vertices");
  CHECK_THROWS_WITH(with_lid_middles(r, r, other, rest, {}),
                    "lid middles: target components: 5 vertex labels for 10 vertices");
}

TEST_CASE("the template's shapes: made whole, or abandoned with an error", "[rigbuild][stages]") {
  rig::Rig tmpl = skin_and_tooth();
  rig::Positions d = rig::Positions::Zero(10, 3);
  d(2, 2) = 0.2f;
  tmpl.shapes.push_back(rig::Blendshape::from_dense("s", d));
  std::atomic<bool> abandon = false;
  const TemplateShapes made = template_shapes(tmpl, &abandon);
  REQUIRE(made.size() == 1);
  CHECK(made.shapes[0](2, 2) == Approx(tmpl.positions(2, 2) + 0.2));
  CHECK(made.gradients[0].size() == static_cast<std::size_t>(tmpl.triangle_count()));
  // A caller that will not read them (avatar_from_photos when the photo has no face) gets no
  // half-made shapes.
  abandon = true;
  CHECK_THROWS_WITH(template_shapes(tmpl, &abandon), "template shapes: abandoned");
}

TEST_CASE("placement: still vertices stay, a part the template moves rigidly is rigid",
          "[rigbuild][stages]") {
  rig::Rig tmpl = skin_and_tooth();
  rig::Positions d = rig::Positions::Zero(10, 3);
  d(2, 2) = 0.2f;                               // the skin moves at one vertex
  for (int v = 6; v < 10; ++v) d(v, 1) = 0.3f;  // the tooth moves as a whole
  tmpl.shapes.push_back(rig::Blendshape::from_dense("s", d));
  const Points rest = tmpl.positions.cast<double>();
  const TargetMesh mesh(rest, tmpl.triangles);
  CHECK(mesh.parts.skin == 0);
  const Correspondence c = identity_correspondence(10, tmpl.triangles);
  const TemplateShapes source = template_shapes(tmpl);
  const Moved moved = classify_motion(c, source, 1e-4);
  CHECK(moved[0] == std::vector<char>{0, 0, 1, 0, 0, 0, 1, 1, 1, 1});
  const BuildOptions options;
  const Placement p = place_components(tmpl, mesh, std::nullopt, c, source, moved, options);
  CHECK(p.role[0] == Role::kFixed);
  CHECK(p.role[2] == Role::kFree);
  CHECK(p.role[7] == Role::kRigid);
  CHECK(p.prescribed() == std::vector<int>{0, 1, 3, 4, 5, 6, 7, 8, 9});
  REQUIRE(p.components.size() == 2);
  CHECK(p.components[0].placement == "anchored");
  CHECK(p.components[1].placement == "rigid");
  // The copy puts the rigid part where its motion takes it and the skin's moved vertex where the
  // template's is.
  const auto copied = copy_motion(rest, c, source, p, moved);
  CHECK((copied[0].row(7) - rest.row(7) - Eigen::RowVector3d(0, 0.3, 0)).norm() < 1e-6);
  CHECK((copied[0].row(2) - rest.row(2) - Eigen::RowVector3d(0, 0, 0.2)).norm() < 1e-6);
  CHECK(p.stays(moved[0], 0));
  CHECK(!p.stays(moved[0], 2));
}
