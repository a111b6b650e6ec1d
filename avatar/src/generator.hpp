#pragma once
// Private: the generator of the default avatar's neutral geometry, shared by the files that build
// its parts: geometry.cpp (the head and the assembly), skin.cpp, mouth.cpp
// (teeth and tongue), eyes.cpp (eyeballs and lids). Centimetres, +y up, +z forward.
#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "model.hpp"

namespace facecast::avatar::detail {

// ---- signed distances ---------------------------------------------------------------------------

inline float sd_ellipsoid(const V3& p, const V3& c, const V3& r) {
  const V3 q = p - c;
  const float k0 = q.cwiseQuotient(r).norm();
  const float k1 = q.cwiseQuotient(r.cwiseProduct(r)).norm();
  if (k1 < 1e-12f) return -r.minCoeff();
  return k0 * (k0 - 1.0f) / k1;
}

inline float sd_round_cone(const V3& p, const V3& a, const V3& b, float ra, float rb) {
  const V3 ab = b - a;
  const float t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0f, 1.0f);
  return (p - (a + t * ab)).norm() - (ra + (rb - ra) * t);
}

inline float smin(float a, float b, float k) {
  const float h = std::max(k - std::abs(a - b), 0.0f) / k;
  return std::min(a, b) - h * h * k * 0.25f;
}
inline float smax(float a, float b, float k) {
  return -smin(-a, -b, k);
}

// The head as a signed-distance function (negative inside), centimetres.
struct HeadSdf {
  V3 cran_c, cran_r, jaw_c, jaw_r, chin_c, chin_r, muzzle_c, muzzle_r, cheek_c[2], cheek_r;
  V3 brow_c, brow_r, orbit_c[2], orbit_r;
  bool features = false;  // nose and ears
  V3 root, tip;
  float root_r = 0, tip_r = 0;
  V3 ala_c[2];
  float ala_r = 0;
  V3 ear_c[2], ear_r, concha_c[2], concha_r;

  float base(const V3& p) const {
    float d = sd_ellipsoid(p, cran_c, cran_r);
    d = smin_ellipsoid(d, p, jaw_c, jaw_r, 2.5f);
    d = smin_ellipsoid(d, p, chin_c, chin_r, 1.6f);
    d = smin_ellipsoid(d, p, muzzle_c, muzzle_r, 1.6f);
    for (const auto& c : cheek_c) d = smin_ellipsoid(d, p, c, cheek_r, 1.8f);
    d = smin_ellipsoid(d, p, brow_c, brow_r, 1.2f);
    for (const auto& c : orbit_c) d = smin_ellipsoid(d, p, c, orbit_r, 1.2f);
    return d;
  }
  // Whether an ellipsoid's value at p is surely >= d + k, where smin(d, value, k) is d itself:
  // with k0 = |q/r| >= |q| / r_max > 1 and k1 = |q/r^2| <= k0 / r_min, sd_ellipsoid's
  // k0 (k0 - 1) / k1 >= (|q| / r_max - 1) r_min; the margin covers float rounding. Skipping such
  // parts gives the same bits, and most points are far from most parts.
  static bool beyond(float d, const V3& p, const V3& c, const V3& r, float k) {
    const float q = (p - c).norm(), r_max = r.maxCoeff();
    return q > r_max && (q / r_max - 1.0f) * r.minCoeff() > d + k + 1e-3f * (1.0f + std::abs(d));
  }
  static float smin_ellipsoid(float d, const V3& p, const V3& c, const V3& r, float k) {
    return beyond(d, p, c, r, k) ? d : smin(d, sd_ellipsoid(p, c, r), k);
  }
  float operator()(const V3& p) const {
    float d = base(p);
    if (!features) return d;
    float nose = sd_round_cone(p, root, tip, root_r, tip_r);
    nose = smin(nose, (p - tip).norm() - tip_r * 1.08f, 0.5f);
    for (const auto& c : ala_c) nose = smin(nose, (p - c).norm() - ala_r, 0.45f);
    d = smin(d, nose, 0.7f);
    for (int s = 0; s < 2; ++s) {
      if (beyond(d, p, ear_c[s], ear_r, 0.9f)) continue;  // smax(e, .) >= e
      const float ear =
          smax(sd_ellipsoid(p, ear_c[s], ear_r), -sd_ellipsoid(p, concha_c[s], concha_r), 0.35f);
      d = smin(d, ear, 0.9f);
    }
    return d;
  }
  V3 gradient(const V3& p) const {
    constexpr float h = 1e-3f;
    const V3 g((*this)(p + V3(h, 0, 0)) - (*this)(p - V3(h, 0, 0)),
               (*this)(p + V3(0, h, 0)) - (*this)(p - V3(0, h, 0)),
               (*this)(p + V3(0, 0, h)) - (*this)(p - V3(0, 0, h)));
    const float n = g.norm();
    return n > 1e-12f ? V3(g / n) : V3(0, 0, 1);
  }
  /// First exit from the head along o + t d (o inside).
  V3 raycast(const V3& o, const V3& d) const {
    float t = 0.0f, prev = 0.0f;
    for (int i = 0; i < 400 && t < 40.0f; ++i) {
      const float v = (*this)(o + t * d);
      if (v > 0.0f) break;
      prev = t;
      t += std::max(0.5f * -v, 0.02f);
    }
    float lo = prev, hi = t;
    for (int i = 0; i < 30; ++i) {
      const float mid = 0.5f * (lo + hi);
      if (mid == lo || mid == hi) break;  // adjacent floats: further halving changes nothing
      ((*this)(o + mid * d) > 0.0f ? hi : lo) = mid;
    }
    return o + 0.5f * (lo + hi) * d;
  }
  /// Newton steps back onto the surface.
  V3 project(V3 p) const {
    for (int i = 0; i < 3; ++i) p -= (*this)(p)*gradient(p);
    return p;
  }
};

// ---- mesh building ------------------------------------------------------------------------------

enum Mat : int {
  kSkinMat,
  kLipsMat,
  kMouthMat,
  kTeethMat,
  kTongueMat,
  kScleraMat,
  kIrisMat,
  kPupilMat,
  kLashMat,
};

enum Group : int {
  kSkinGroup,
  kLipUpper,
  kLipLower,
  kTeethUpperGroup,
  kTeethLowerGroup,
  kTongueGroup,
  kEyeballLeft,
  kEyeballRight,
  kLidUpperLeft,
  kLidLowerLeft,
  kLidUpperRight,
  kLidLowerRight,
};

struct Builder {
  std::vector<V3> pos;
  std::vector<VertexInfo> info;
  std::vector<Eigen::Vector3i> tris;
  std::vector<int> mat, group;

  int add(const V3& p, const VertexInfo& vi) {
    pos.push_back(p);
    info.push_back(vi);
    return static_cast<int>(pos.size()) - 1;
  }
  void tri(int a, int b, int c, int m, int g) {
    tris.emplace_back(a, b, c);
    mat.push_back(m);
    group.push_back(g);
  }
  // Quad a-b-c-d (in order around it), split along a-c: the split never depends on positions, so
  // every parameter set gives the same triangles.
  void quad(int a, int b, int c, int d, int m, int g) {
    tri(a, b, c, m, g);
    tri(a, c, d, m, g);
  }
  // Quads between consecutive rows; `wrap` closes each row into a loop.
  void grid(const std::vector<std::vector<int>>& rows, bool wrap, int m, int g) {
    for (std::size_t r = 0; r + 1 < rows.size(); ++r) {
      const auto& A = rows[r];
      const auto& B = rows[r + 1];
      const std::size_t n = A.size();
      for (std::size_t i = 0; i < (wrap ? n : n - 1); ++i) {
        const std::size_t j = (i + 1) % n;
        quad(A[i], A[j], B[j], B[i], m, g);
      }
    }
  }
  // Triangles from `center` to each edge of the loop `ring`: a cap on the first row of a tube.
  void fan(int center, const std::vector<int>& ring, int m, int g) {
    for (std::size_t i = 0; i < ring.size(); ++i)
      tri(center, ring[(i + 1) % ring.size()], ring[i], m, g);
  }
  // The same for the last row of a tube (the loop taken the other way round).
  void fan_end(int center, const std::vector<int>& ring, int m, int g) {
    fan(center, std::vector<int>(ring.rbegin(), ring.rend()), m, g);
  }
  // Orients the triangles in [first, end) so that the closed part they form has positive volume.
  void orient_closed(std::size_t first) {
    double vol = 0;
    for (std::size_t t = first; t < tris.size(); ++t) {
      const auto& f = tris[t];
      vol += pos[f[0]].cast<double>().dot(pos[f[1]].cast<double>().cross(pos[f[2]].cast<double>()));
    }
    if (vol < 0) flip(first);
  }
  // Orients an open sheet so that triangle `probe`'s normal points along `out`.
  void orient_open(std::size_t first, std::size_t probe, const V3& out) {
    const auto& f = tris[probe];
    const V3 n = (pos[f[1]] - pos[f[0]]).cross(pos[f[2]] - pos[f[0]]);
    if (n.dot(out) < 0) flip(first);
  }
  void flip(std::size_t first) {
    for (std::size_t t = first; t < tris.size(); ++t) std::swap(tris[t][1], tris[t][2]);
  }
};

// ---- the generator ------------------------------------------------------------------------------

/// Builds the parts in order (setup_head first: every part is placed on the head); each part adds
/// its vertices and triangles to `b` and its landmarks to `landmarks`.
struct Generator {
  AvatarParams prm;
  HeadSdf head;
  Frames f;
  Builder b;
  std::vector<rig::Landmark> landmarks;
  V3 ray_origin, mouth_axis, mouth_x, mouth_y;
  float mouth_c = 0, mu0 = 0.006f, proj_f = 0;
  int n_around = 140;
  float vermilion_upper = 0, vermilion_lower = 0;
  float cavity_w = 0, cavity_h = 0, cavity_y = 0, cavity_d = 0, tunnel_open = 0.32f;
  int j_lip = 8, j_bag = 26;
  V3 eye_axis[2];
  float rim_wide = deg(50), rim_tall = deg(40);
  V3 nostril_c[2], nostril_axis;

  explicit Generator(const AvatarParams& p) : prm(p) {}

  // The head and the frames of mouth and eyes (geometry.cpp).
  float lower_y(float y) const;
  void setup_head();
  void shape_head();
  void place_mouth();
  void place_eyes();

  // Skin (skin.cpp).
  void build_skin();
  V3 direction(float mu, float nu) const;
  float lip_profile(float u) const;
  std::vector<std::vector<int>> skin_rings(
      std::size_t count, const std::function<V3(std::size_t ring, int i, VertexInfo& vi)>& place);
  void relax_outer(const std::vector<std::vector<int>>& outer);
  void shape_outer(int v);
  float brow_weight(const V3& p, int s) const;
  static constexpr float kArch = 0.15f;  // the cavity's front curves back like the dental arch
  V3 inner_point(const V3& contact, float s, float s_lip, float nu, float* att) const;
  void skin_material(std::size_t t);
  void jaw_weights();

  // Teeth and tongue (mouth.cpp).
  void build_teeth(bool upper);
  void build_tongue();

  // Eyeballs and lids (eyes.cpp).
  void build_eyeball(int side);
  void build_lid(int side, bool upper);

  // UVs and textures (textures.cpp), once the parts and materials are in `m`.
  void paint_textures(Model& m) const;
};

}  // namespace facecast::avatar::detail
