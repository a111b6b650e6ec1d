#include <catch2/catch.hpp>
#include <random>

#include "facecast/core/error.hpp"
#include "facecast/rig/blend.hpp"
#include "facecast/rig/rig_io.hpp"

using namespace facecast;
using namespace facecast::rig;

namespace {
Rig grid_rig(int n) {
  // An n x n grid of quads in the z=0 plane, with two shapes.
  Rig r;
  r.positions.resize(n * n, 3);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) r.positions.row(y * n + x) << float(x), float(y), 0.0f;
  r.triangles.resize(2 * (n - 1) * (n - 1), 3);
  int f = 0;
  for (int y = 0; y + 1 < n; ++y)
    for (int x = 0; x + 1 < n; ++x) {
      const int a = y * n + x;
      r.triangles.row(f++) << a, a + 1, a + n + 1;
      r.triangles.row(f++) << a, a + n + 1, a + n;
    }
  r.triangle_material.assign(f, 0);
  r.materials.push_back(Material::solid("skin", {1, 1, 1, 1}));
  r.normals = vertex_normals(r.positions, r.triangles);
  Positions bump = Positions::Zero(n * n, 3);
  bump(n + 1, 2) = 1.0f;
  r.shapes.push_back(Blendshape::from_dense("bump", bump));
  Positions shift = Positions::Zero(n * n, 3);
  shift.col(0).setConstant(0.5f);
  r.shapes.push_back(Blendshape::from_dense("shift", shift));
  return r;
}
}  // namespace

TEST_CASE("zero weights give the neutral and weight 1 gives the shape", "[rig][blend]") {
  const Rig r = grid_rig(6);
  Blender b(r);
  Positions p, n;
  std::vector<float> w{0, 0};
  b.apply(w, p, n);
  CHECK(p == r.positions);
  CHECK((n - r.normals).cwiseAbs().maxCoeff() < 1e-6f);
  w = {1, 0};
  b.apply(w, p, n);
  CHECK(p(7, 2) == 1.0f);
  CHECK((p - r.positions).cwiseAbs().sum() == 1.0f);
  CHECK(n.row(7).z() > 0.99f);  // a bump seen from above still faces +z at its tip
  w = {0.5f, 2.0f};
  b.apply(w, p, n);
  CHECK(p(7, 2) == 0.5f);
  CHECK(p(0, 0) == 1.0f);
  CHECK(r.shapes[0].vertices.size() == 1);
  w = {1};
  CHECK_THROWS_AS(b.apply(w, p, n), Error);
}
