// Deformation transfer and virtual edges on small synthetic meshes (no shared data needed).
#include <catch2/catch.hpp>
#include <cmath>

#include "facecast/core/error.hpp"
#include "facecast/rig/intersections.hpp"
#include "facecast/rigbuild/build.hpp"
#include "facecast/rigbuild/correspondence.hpp"
#include "facecast/rigbuild/virtual_edges.hpp"

using namespace facecast;
using namespace facecast::rigbuild;

namespace {

// A closed box-like surface: two parallel n x n grids (a "double layer" like lips) joined at
// their rims, so the layers are close in space (gap) but far apart along the surface.
rig::Rig double_layer(int n, float gap) {
  rig::Rig r;
  const int per = n * n;
  r.positions.resize(2 * per, 3);
  for (int layer = 0; layer < 2; ++layer) {
    for (int y = 0; y < n; ++y) {
      for (int x = 0; x < n; ++x) {
        r.positions.row(layer * per + y * n + x) << float(x), float(y), layer ? -gap : 0.0f;
      }
    }
  }
  std::vector<Eigen::Vector3i> tris;
  for (int layer = 0; layer < 2; ++layer) {
    for (int y = 0; y + 1 < n; ++y) {
      for (int x = 0; x + 1 < n; ++x) {
        const int a = layer * per + y * n + x;
        if (layer == 0) {
          tris.emplace_back(a, a + 1, a + n + 1);
          tris.emplace_back(a, a + n + 1, a + n);
        } else {
          tris.emplace_back(a, a + n + 1, a + 1);
          tris.emplace_back(a, a + n, a + n + 1);
        }
      }
    }
  }
  // Join the rims of the two layers with a strip along the left edge (x = 0) only, so the layers
  // form one component whose far sides are a long way apart along the surface.
  for (int y = 0; y + 1 < n; ++y) {
    const int a = y * n, b = (y + 1) * n, c = per + y * n, d = per + (y + 1) * n;
    tris.emplace_back(a, c, d);
    tris.emplace_back(a, d, b);
  }
  r.triangles.resize(static_cast<Eigen::Index>(tris.size()), 3);
  for (std::size_t i = 0; i < tris.size(); ++i)
    r.triangles.row(static_cast<Eigen::Index>(i)) = tris[i].transpose();
  r.triangle_material.assign(tris.size(), 0);
  r.materials.push_back(rig::Material::solid("skin", {1, 1, 1, 1}));
  r.normals = rig::vertex_normals(r.positions, r.triangles);
  return r;
}

}  // namespace

TEST_CASE("identity deformation gives back the target", "[rigbuild][transfer]") {
  rig::Rig tmpl = double_layer(8, 0.5f);
  // One shape that moves nothing but a corner slightly, so the build has work; its gradients are
  // the identity almost everywhere.
  rig::Positions d = rig::Positions::Zero(tmpl.vertex_count(), 3);
  d(63, 2) = 0.3f;
  tmpl.shapes.push_back(rig::Blendshape::from_dense("corner", d));
  rig::Rig target = tmpl;
  target.shapes.clear();
  target.positions *= 1.3f;  // another size, same topology
  BuildOptions opt;
  opt.virtual_edges = VirtualEdgeMode::kOff;
  const auto r = build_rig(tmpl, target, opt);
  REQUIRE(r.rig.shapes.size() == 1);
  const rig::Positions got = r.rig.shapes[0].dense(target.vertex_count());
  // Vertices the template shape leaves still are exactly still.
  for (int v = 0; v < target.vertex_count(); ++v) {
    if (v != 63) CHECK(got.row(v).norm() < 0.05f);
  }
  CHECK(got(63, 2) > 0.2f);
}

TEST_CASE("a pure translation of a separate part moves it rigidly", "[rigbuild][transfer]") {
  rig::Rig tmpl = double_layer(6, 0.5f);
  // Add a separate triangle pair (a "tooth") that the template shape lifts by 0.25.
  const int base = tmpl.vertex_count();
  tmpl.positions.conservativeResize(base + 4, 3);
  tmpl.positions.bottomRows(4) << 2, 2, 3, 3, 2, 3, 3, 3, 3, 2, 3, 3;
  tmpl.triangles.conservativeResize(tmpl.triangle_count() + 2, 3);
  tmpl.triangles.bottomRows(2) << base, base + 1, base + 2, base, base + 2, base + 3;
  tmpl.triangle_material.push_back(0);
  tmpl.triangle_material.push_back(0);
  tmpl.normals = rig::vertex_normals(tmpl.positions, tmpl.triangles);
  rig::Positions d = rig::Positions::Zero(tmpl.vertex_count(), 3);
  for (int k = 0; k < 4; ++k) d(base + k, 1) = 0.25f;
  tmpl.shapes.push_back(rig::Blendshape::from_dense("lift", d));
  rig::Rig target = tmpl;
  target.shapes.clear();
  BuildOptions opt;
  opt.virtual_edges = VirtualEdgeMode::kOff;
  const auto r = build_rig(tmpl, target, opt);
  const rig::Positions got = r.rig.shapes[0].dense(target.vertex_count());
  for (int k = 0; k < 4; ++k) CHECK(std::abs(got(base + k, 1) - 0.25f) < 1e-4f);
  CHECK(got.topRows(base).norm() == 0.0f);
  REQUIRE(r.components.size() == 2);
  CHECK(r.components[1].placement == "rigid");
}

TEST_CASE("virtual edges span the gap of a double layer and nothing else",
          "[rigbuild][virtual_edges]") {
  const rig::Rig r = double_layer(12, 0.4f);
  const Points p = r.positions.cast<double>();
  VirtualEdgeOptions opt;
  opt.d = 0.6;
  opt.f = 3.0;
  VirtualEdgeStats stats;
  const auto edges = detect_virtual_edges(p, r.triangles, opt, &stats);
  REQUIRE(!edges.empty());
  CHECK(stats.qualifying_pairs > 0);
  for (const auto& e : edges) {
    // Every edge crosses from one layer to the other, away from the joined rim at x = 0.
    CHECK((e.a < 144) != (e.b < 144));
    CHECK((p.row(e.a) - p.row(e.b)).norm() < 0.6);
    CHECK(p(e.a, 0) >= 1.0);
  }
  // Density control: a larger spacing places fewer edges.
  opt.spacing = 3.0;
  CHECK(detect_virtual_edges(p, r.triangles, opt).size() < edges.size());
  // f must be at least 2.
  opt.f = 1.5;
  CHECK_THROWS_AS(detect_virtual_edges(p, r.triangles, opt), Error);
}

TEST_CASE("broken rig-build inputs are rejected with a clear error", "[rigbuild][errors]") {
  rig::Rig tmpl = double_layer(5, 0.5f);
  rig::Positions d = rig::Positions::Zero(tmpl.vertex_count(), 3);
  d(0, 2) = 0.1f;
  tmpl.shapes.push_back(rig::Blendshape::from_dense("s", d));
  rig::Rig target = tmpl;
  target.shapes.clear();
  auto message = [&](const rig::Rig& t, const BuildOptions& o) {
    try {
      build_rig(tmpl, t, o);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  BuildOptions opt;
  rig::Rig nan_target = target;
  nan_target.positions(3, 0) = std::nanf("");
  CHECK(message(nan_target, opt) == "target: non-finite vertex coordinate");

  rig::Rig flat = target;
  flat.positions.row(flat.triangles(0, 1)) = flat.positions.row(flat.triangles(0, 0));
  CHECK(message(flat, opt).find("has zero area") != std::string::npos);

  rig::Rig other = double_layer(6, 0.5f);
  CHECK(message(other, opt).find("no face found") != std::string::npos);  // automatic landmarks
  CHECK(message(other, opt).find("give --markers") != std::string::npos);
  opt.auto_landmarks = false;
  CHECK(message(other, opt).find("topology differs from the template") != std::string::npos);
  opt.auto_landmarks = true;

  rig::Rig empty = target;
  empty.triangles.resize(0, 3);
  empty.triangle_material.clear();
  CHECK(message(empty, opt) == "target: mesh has no triangles");

  opt.fixed = {999};
  CHECK(message(target, opt).find("--fixed: vertex 999 out of range") != std::string::npos);
}

TEST_CASE("the same triangles in another order are the same topology", "[rigbuild][transfer]") {
  Triangles a(3, 3), b(3, 3), flipped(3, 3);
  a << 0, 1, 2, 1, 3, 2, 2, 3, 4;
  b << 3, 4, 2, 0, 1, 2, 3, 2, 1;        // permuted, corners rotated
  flipped << 0, 2, 1, 1, 3, 2, 2, 3, 4;  // one triangle reversed: another surface
  const auto same = same_topology_correspondence(5, a, 5, b);
  REQUIRE(same.has_value());
  CHECK(same->map.sources[0] == std::vector<int>{2});
  CHECK(same->map.sources[1] == std::vector<int>{0});
  CHECK(same->map.sources[2] == std::vector<int>{1});
  CHECK(!same_topology_correspondence(5, a, 5, flipped).has_value());
  CHECK(!same_topology_correspondence(5, a, 6, a).has_value());
  CHECK(same_topology_correspondence(5, a, 5, a)->map.sources[1] == std::vector<int>{1});
}

TEST_CASE("the build options file mirrors BuildOptions", "[rigbuild][config]") {
  const BuildOptions file = load_build_options(), code;
  CHECK(file.virtual_edges == code.virtual_edges);
  CHECK(file.lambda == code.lambda);
  CHECK(file.gap_scale_limit == code.gap_scale_limit);
  CHECK(file.closing_rounds == code.closing_rounds);
  CHECK(file.still_tolerance == code.still_tolerance);
  CHECK(file.rigid_tolerance == code.rigid_tolerance);
  CHECK(file.solver == code.solver);
  CHECK(file.ve.d == code.ve.d);
  CHECK(file.ve.f == code.ve.f);
  CHECK(file.ve.per_vertex == code.ve.per_vertex);
  CHECK(file.ve.spacing == code.ve.spacing);
  CHECK(file.registration.closest_weights == code.registration.closest_weights);
  CHECK(file.registration.iterations_per_step == code.registration.iterations_per_step);
  CHECK(file.registration.smoothness == code.registration.smoothness);
  CHECK(file.registration.identity == code.registration.identity);
  CHECK(file.registration.rest_pull == code.registration.rest_pull);
  CHECK(file.registration.max_distance == code.registration.max_distance);
  CHECK(file.contacts.enabled == code.contacts.enabled);
  CHECK(file.contacts.margin == code.contacts.margin);
  CHECK(file.contacts.part_margin == code.contacts.part_margin);
  CHECK(file.contacts.weight == code.contacts.weight);
  CHECK(file.contacts.rounds == code.contacts.rounds);
  CHECK(file.eye_look.in_out == code.eye_look.in_out);
  CHECK(file.eye_look.up == code.eye_look.up);
  CHECK(file.eye_look.down == code.eye_look.down);
}

TEST_CASE("contacts solved on a patch match a full solve with the same term, and stay local",
          "[rigbuild][transfer][contacts]") {
  const rig::Rig mesh = double_layer(10, 0.5f);
  TransferSetup setup;
  setup.target_rest = mesh.positions.cast<double>();
  setup.target_faces = mesh.triangles;
  setup.map = TriangleMap::identity(mesh.triangle_count());
  setup.dirichlet = {0, 9, 90, 99};  // corners of the top layer
  // Source gradients: a shear of every triangle.
  Eigen::Matrix3d shear = Eigen::Matrix3d::Identity();
  shear(2, 0) = 0.2;
  const Gradients grads(static_cast<std::size_t>(mesh.triangle_count()), shear);
  Points prescribed(4, 3);
  for (int i = 0; i < 4; ++i)
    prescribed.row(i) = setup.target_rest.row(setup.dirichlet[static_cast<std::size_t>(i)]);
  const Transfer plain(setup);
  const Points x0 = plain.solve({&grads}, {prescribed}, {})[0];

  // A contact between top vertex 45 and bottom vertex 145 (weights 1, 0, 0) pulling them together
  // is a virtual edge with lambda = weight.
  const std::vector<Contact> contacts = {{45, {145, 146, 155}, {1.0, 0.0, 0.0}}};
  Points target(1, 3);
  target << 0.0, 0.0, 0.1;
  const double weight = 50;
  const Points local = plain.solve_with_contacts(x0, {}, contacts, target, weight, 1000);
  setup.virtual_edges = {{45, 145}};
  setup.lambda = weight;
  const Points full = Transfer(setup).solve({&grads}, {prescribed}, {target})[0];
  CHECK((local - full).cwiseAbs().maxCoeff() < 1e-8);
  CHECK((local.row(45) - local.row(145) - target).norm() < 0.05);

  // With two rings only the vertices near the contact move; held vertices never do.
  std::vector<char> held(static_cast<std::size_t>(mesh.vertex_count()), 0);
  held[145] = 1;
  const Points near = plain.solve_with_contacts(x0, held, contacts, target, weight, 2);
  CHECK((near.row(145) - x0.row(145)).norm() == 0.0);
  CHECK((near.row(45) - x0.row(45)).norm() > 0.05);
  CHECK((near.row(0) - x0.row(0)).norm() == 0.0);
  CHECK((near.row(72) - x0.row(72)).norm() == 0.0);  // four rows away
}

TEST_CASE("contacts hold apart layers that the transfer pushes through each other",
          "[rigbuild][contacts]") {
  // Template: two layers 0.5 apart; the shape dents the top layer 0.3 towards the bottom one.
  rig::Rig tmpl = double_layer(9, 0.5f);
  rig::Positions d = rig::Positions::Zero(tmpl.vertex_count(), 3);
  for (int y = 1; y < 8; ++y)
    for (int x = 1; x < 8; ++x) {
      const double r = std::hypot(x - 4.0, y - 4.0);
      if (r < 3) d(y * 9 + x, 2) = static_cast<float>(-0.3 * 0.5 * (1 + std::cos(M_PI * r / 3)));
    }
  tmpl.shapes.push_back(rig::Blendshape::from_dense("dent", d));
  // Target: twice as wide and long, as far apart. Deformation transfer keeps the dent's slopes, so
  // it is twice as deep (0.6) and goes through the bottom layer; the template's displacement
  // copied would not (0.3).
  rig::Rig target = tmpl;
  target.shapes.clear();
  target.positions.leftCols(2) *= 2.0f;
  BuildOptions opt;
  opt.virtual_edges = VirtualEdgeMode::kOff;
  const auto crossings = [](const rig::Rig& r) {
    return rig::find_intersections(r.positions + r.shapes[0].dense(r.vertex_count()), r.triangles)
        .count;
  };
  opt.contacts.enabled = false;
  const auto without = build_rig(tmpl, target, opt);
  CHECK(crossings(without.rig) > 0);
  CHECK(without.rig.shapes[0].max_displacement() > 0.5f);
  opt.contacts.enabled = true;
  const auto with = build_rig(tmpl, target, opt);
  CHECK(with.watched_pairs > 0);
  CHECK(with.quality[0].crossings > 0);
  CHECK(with.quality[0].crossings_left == 0);
  CHECK(with.quality[0].contacts > 0);
  CHECK(crossings(with.rig) == 0);
  // The dent is still there: the contacts hold the layers apart, they do not undo the shape.
  CHECK(with.rig.shapes[0].max_displacement() > 0.3f);
}

TEST_CASE("where the copied motion presses a thinner gap shut, contacts keep the layers apart",
          "[rigbuild][contacts]") {
  // A dent in the template's top layer comes down 0.45 towards a layer 0.5 below it; the
  // target's layers are 0.2 apart, so the template's motion copied onto the target passes
  // through its bottom layer (fuller lips pressed together as far as the template's).
  const int n = 10;
  rig::Rig tmpl = double_layer(n, 0.5f);
  rig::Positions d = rig::Positions::Zero(tmpl.vertex_count(), 3);
  for (int v : {5 * n + 5, 5 * n + 6, 6 * n + 5, 6 * n + 6}) d(v, 2) = -0.45f;
  tmpl.shapes.push_back(rig::Blendshape::from_dense("dent", d));
  const rig::Rig target = double_layer(n, 0.2f);
  const auto crossings = [](const BuildResult& r) {
    const rig::Positions p = r.rig.positions + r.rig.shapes[0].dense(r.rig.vertex_count());
    return rig::find_intersections(p, r.rig.triangles).count;
  };
  BuildOptions opt;
  opt.virtual_edges = VirtualEdgeMode::kOff;  // the contacts alone
  const auto on = build_rig(tmpl, target, opt);
  opt.contacts.enabled = false;
  const auto off = build_rig(tmpl, target, opt);
  CHECK(crossings(off) > 0);
  CHECK(on.quality[0].copy_crossings > 0);  // the copy crosses: it was smoothed there
  CHECK(on.quality[0].copy_crossings_left == 0);
  CHECK(crossings(on) == 0);
  // The dent still comes down towards the bottom layer.
  CHECK(on.rig.shapes[0].dense(target.vertex_count())(5 * n + 5, 2) < -0.05f);
}

TEST_CASE("a layer pressed onto a part that moves rigidly is kept off it", "[rigbuild][contacts]") {
  // The template's bottom layer is a rigid part (a row of teeth): the shape lifts it 0.05 and
  // brings a dent of the top layer (a lip) 0.4 down towards it. The target's layers are 0.2
  // apart, so the template's motion copied onto the target passes through the part.
  const int n = 10;
  const auto separate_layers = [&](float gap) {  // without the strip that joins them
    rig::Rig r = double_layer(n, gap);
    const Eigen::Index kept = 4 * (n - 1) * (n - 1);
    r.triangles.conservativeResize(kept, 3);
    r.triangle_material.resize(static_cast<std::size_t>(kept));
    return r;
  };
  rig::Rig tmpl = separate_layers(0.5f);
  rig::Positions d = rig::Positions::Zero(tmpl.vertex_count(), 3);
  for (int v = n * n; v < 2 * n * n; ++v) d(v, 2) = 0.05f;
  for (int v : {5 * n + 5, 5 * n + 6, 6 * n + 5, 6 * n + 6}) d(v, 2) = -0.4f;
  tmpl.shapes.push_back(rig::Blendshape::from_dense("press", d));
  const rig::Rig target = separate_layers(0.2f);
  const auto crossings = [](const BuildResult& r) {
    const rig::Positions p = r.rig.positions + r.rig.shapes[0].dense(r.rig.vertex_count());
    return rig::find_intersections(p, r.rig.triangles).count;
  };
  BuildOptions opt;
  opt.virtual_edges = VirtualEdgeMode::kOff;
  const auto on = build_rig(tmpl, target, opt);
  opt.contacts.enabled = false;
  const auto off = build_rig(tmpl, target, opt);
  REQUIRE(on.components.size() == 2);
  CHECK(on.components[1].placement == "rigid");
  CHECK(crossings(off) > 0);
  CHECK(on.quality[0].part_crossings > 0);  // the copy crosses the part: it was moved out
  CHECK(on.quality[0].part_crossings_left == 0);
  CHECK(crossings(on) == 0);
  // The part moved as the template's did; the dent still comes down towards it.
  const rig::Positions moved = on.rig.shapes[0].dense(target.vertex_count());
  CHECK(moved(n * n + 3, 2) == Approx(0.05f));
  CHECK(moved(5 * n + 5, 2) < -0.02f);
}
