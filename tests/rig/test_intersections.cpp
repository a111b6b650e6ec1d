#include <catch2/catch.hpp>
#include <chrono>

#include "facecast/core/error.hpp"
#include "facecast/rig/intersections.hpp"
#include "facecast/rig/rig_io.hpp"
#include "sanitizers.hpp"
#include "test_data.hpp"

using namespace facecast::rig;
using V = Eigen::Vector3d;

TEST_CASE("triangle pairs: crossing, apart, touching, coplanar", "[rig][intersections]") {
  const V a(0, 0, 0), b(2, 0, 0), c(0, 2, 0);
  // A triangle piercing the first one.
  CHECK(triangles_intersect(a, b, c, V(0.5, 0.5, -1), V(0.5, 0.5, 1), V(1.5, 1.5, 1)));
  // Parallel above it.
  CHECK_FALSE(triangles_intersect(a, b, c, V(0, 0, 1), V(2, 0, 1), V(0, 2, 1)));
  // Crossing the plane outside the triangle.
  CHECK_FALSE(triangles_intersect(a, b, c, V(3, 3, -1), V(3, 3, 1), V(4, 4, 1)));
  // Touching at a point: a contact counts; a gap within epsilon counts too.
  CHECK(triangles_intersect(a, b, c, V(0.5, 0.5, 0), V(0.5, 0.5, 1), V(1, 0.5, 1)));
  CHECK_FALSE(triangles_intersect(a, b, c, V(0.5, 0.5, 1e-3), V(0.5, 0.5, 1), V(1, 0.5, 1)));
  CHECK(triangles_intersect(a, b, c, V(0.5, 0.5, 1e-3), V(0.5, 0.5, 1), V(1, 0.5, 1), 1e-2));
  // Coplanar: overlapping, contained, disjoint.
  CHECK(triangles_intersect(a, b, c, V(1, 1, 0), V(3, 1, 0), V(1, 3, 0)));
  CHECK(triangles_intersect(a, b, c, V(0.2, 0.2, 0), V(0.6, 0.2, 0), V(0.2, 0.6, 0)));
  CHECK_FALSE(triangles_intersect(a, b, c, V(3, 3, 0), V(4, 3, 0), V(3, 4, 0)));
  // Degenerate triangles never intersect.
  CHECK_FALSE(triangles_intersect(a, a, a, V(0.5, 0.5, -1), V(0.5, 0.5, 1), V(1.5, 1.5, 1)));
}

TEST_CASE("mesh self-intersections skip neighbours and honour ignore", "[rig][intersections]") {
  // Two crossing quads plus a third quad sharing an edge with the first.
  Positions p(10, 3);
  p << 0, 0, 0, 2, 0, 0, 2, 2, 0, 0, 2, 0,       //
      1, 1, -1, 1, 1, 1, 1.5, 3, 1, 1.5, 3, -1,  //
      4, 0, 0, 4, 2, 0;
  Triangles t(6, 3);
  t << 0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7, 1, 8, 9, 1, 9, 2;
  const auto r = find_intersections(p, t);
  CHECK(r.count >= 1);
  for (const auto& [x, y] : r.pairs) {
    CHECK(x < y);
    CHECK(x < 2);
    CHECK((y == 2 || y == 3));
  }
  IntersectionOptions opt;
  opt.ignore = [](int x, int y) { return x < 2 && y >= 2 && y < 4; };
  CHECK(find_intersections(p, t, opt).count == 0);
  opt = {};
  opt.max_listed = 0;
  const auto counted = find_intersections(p, t, opt);
  CHECK(counted.count == r.count);
  CHECK(counted.pairs.empty());
  // Only pairs with an active triangle: the crossing quad active finds them all, the third quad
  // alone finds none; both ways list each pair once.
  opt = {};
  opt.active = {0, 0, 1, 1, 0, 0};
  CHECK(find_intersections(p, t, opt).pairs == r.pairs);
  opt.active = {0, 0, 0, 0, 1, 1};
  CHECK(find_intersections(p, t, opt).count == 0);
  opt.active = {1, 1, 1, 1, 1, 1};
  CHECK(find_intersections(p, t, opt).pairs == r.pairs);
  opt.active = {1};
  CHECK_THROWS_AS(find_intersections(p, t, opt), facecast::Error);
  // Moving the crossing quad away removes the intersections.
  p.middleRows(4, 4).col(0).array() += 10;
  CHECK(find_intersections(p, t).count == 0);
}

TEST_CASE("ICT FaceKit: intersection check is fast and stable", "[rig][intersections][realtime]") {
  const auto dir = facecast::test::ict_dir();
  if (!facecast::test::require_data(dir / "generic_neutral_mesh.obj")) return;
  const Rig rig = read_obj(dir / "generic_neutral_mesh.obj");
  const auto t0 = std::chrono::steady_clock::now();
  const auto r = find_intersections(rig.positions, rig.triangles);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  WARN("ICT neutral (" << rig.triangle_count() << " triangles): " << r.count
                       << " intersecting pairs in " << ms << " ms");
#if defined(NDEBUG) && !defined(FACECAST_ASAN)
  CHECK(ms < 1000.0);
#endif
  // A deformation that pushes a face region through itself must be detected.
  Positions squashed = rig.positions;
  const float mid = rig.positions.col(2).mean();
  for (int v = 0; v < rig.vertex_count(); ++v)
    if (squashed(v, 2) > mid)
      squashed(v, 2) = mid - (squashed(v, 2) - mid);  // mirror the front back
  CHECK(find_intersections(squashed, rig.triangles).count > r.count);
}
