// The default avatar's neutral geometry: skin (head surface folded into lips, mouth cavity and eye
// sockets), teeth, tongue, eyeballs and eyelids. See avatar.hpp for the overview.
//
// The skin is a grid of rings around the mouth. Outside the lip line the rings are elliptic
// coordinates (x, y) = c (cosh(mu + mu0) cos nu, sinh(mu + mu0) sin nu): at mu = 0 they are the lip
// line itself, a slit whose upper and lower edges are 2 c sinh(mu0) apart (the lips meet). The
// plane is mapped conformally onto directions around the mouth axis (stereographic projection) and
// each direction is ray-cast from a point inside the head onto a signed-distance model of the head
// (skull, jaw, chin, cheeks, brow ridge, nose, ears). Inside the lip line the same rings continue
// as the inner lips and then a closed bag, the mouth cavity, ending in a pole at the throat. Around
// each eye the surface is folded back into a socket: a bowl behind the eyeball.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "avatar_model.hpp"

namespace facecast::anim::avatar_detail {
namespace {

// ---------------------------------------------------------------------------------------------
// Signed distances

float sd_ellipsoid(const V3& p, const V3& c, const V3& r) {
  const V3 q = p - c;
  const float k0 = q.cwiseQuotient(r).norm();
  const float k1 = q.cwiseQuotient(r.cwiseProduct(r)).norm();
  if (k1 < 1e-12f) return -r.minCoeff();
  return k0 * (k0 - 1.0f) / k1;
}

float sd_round_cone(const V3& p, const V3& a, const V3& b, float ra, float rb) {
  const V3 ab = b - a;
  const float t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0f, 1.0f);
  return (p - (a + t * ab)).norm() - (ra + (rb - ra) * t);
}

float smin(float a, float b, float k) {
  const float h = std::max(k - std::abs(a - b), 0.0f) / k;
  return std::min(a, b) - h * h * k * 0.25f;
}
float smax(float a, float b, float k) {
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
    d = smin(d, sd_ellipsoid(p, jaw_c, jaw_r), 2.5f);
    d = smin(d, sd_ellipsoid(p, chin_c, chin_r), 1.6f);
    d = smin(d, sd_ellipsoid(p, muzzle_c, muzzle_r), 1.6f);
    for (const auto& c : cheek_c) d = smin(d, sd_ellipsoid(p, c, cheek_r), 1.8f);
    d = smin(d, sd_ellipsoid(p, brow_c, brow_r), 1.2f);
    for (const auto& c : orbit_c) d = smin(d, sd_ellipsoid(p, c, orbit_r), 1.2f);
    return d;
  }
  float operator()(const V3& p) const {
    float d = base(p);
    if (!features) return d;
    float nose = sd_round_cone(p, root, tip, root_r, tip_r);
    nose = smin(nose, (p - tip).norm() - tip_r * 1.08f, 0.5f);
    for (const auto& c : ala_c) nose = smin(nose, (p - c).norm() - ala_r, 0.45f);
    d = smin(d, nose, 0.7f);
    for (int s = 0; s < 2; ++s) {
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

// ---------------------------------------------------------------------------------------------
// Mesh building

enum Mat : int {
  kSkinMat,
  kLipsMat,
  kMouthMat,
  kTeethMat,
  kTongueMat,
  kScleraMat,
  kIrisMat,
  kPupilMat,
  kBrowMat,
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
  void fan(int center, const std::vector<int>& ring, int m, int g) {
    for (std::size_t i = 0; i < ring.size(); ++i)
      tri(center, ring[(i + 1) % ring.size()], ring[i], m, g);
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

// ---------------------------------------------------------------------------------------------

struct Generator {
  AvatarParams prm;
  HeadSdf head;
  Frames f;
  Builder b;
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

  float lower_y(float y) const {  // scales heights below the nose with jaw_length
    constexpr float y_nose = -1.6f;
    return y < y_nose ? y_nose + (y - y_nose) * prm.jaw_length : y;
  }

  void setup_head() {
    const float fw = prm.face_width;
    head.cran_c = V3(0, 1.4f, -0.8f);
    head.cran_r = V3(7.3f * fw, 8.5f, 9.2f);
    head.jaw_c = V3(0, lower_y(-4.0f), 1.6f);
    head.jaw_r = V3(5.5f * fw, 4.6f * prm.jaw_length, 6.5f);
    head.chin_c = V3(0, lower_y(-7.8f), 5.3f);
    head.chin_r = V3(2.7f * fw, 1.7f * prm.jaw_length, 2.3f);
    head.muzzle_c = V3(0, lower_y(-4.5f), 5.9f);
    head.muzzle_r = V3(3.4f * fw, 2.6f * prm.jaw_length, 2.9f);
    for (int s = 0; s < 2; ++s) head.cheek_c[s] = V3((s ? -3.9f : 3.9f) * fw, -1.9f, 4.7f);
    head.cheek_r = V3(2.6f * fw, 2.3f, 2.5f);
    head.brow_c = V3(0, 3.5f, 5.6f);
    head.brow_r = V3(5.4f * fw, 1.3f, 2.4f);
    for (int s = 0; s < 2; ++s) head.orbit_c[s] = V3((s ? -3.3f : 3.3f) * fw, 1.4f, 5.6f);
    head.orbit_r = V3(2.5f * fw, 2.0f, 1.9f);
    head.features = false;

    // Nose, placed on the base surface.
    const float nl = prm.nose_length;
    const V3 inside(0, 0, 0);
    const V3 root_s = head.raycast(V3(0, 1.5f, 0), V3(0, 0, 1));
    head.root = root_s - V3(0, 0, 0.35f);
    head.root_r = 0.5f;
    const float tip_y = 1.5f - 2.9f * nl;
    const V3 tip_s = head.raycast(V3(0, tip_y, 0), V3(0, 0, 1));
    head.tip = tip_s + V3(0, 0, 1.45f * nl);
    head.tip_r = 0.8f;
    for (int s = 0; s < 2; ++s) head.ala_c[s] = head.tip + V3(s ? -0.85f : 0.85f, -0.25f, -0.95f);
    head.ala_r = 0.6f;
    for (int s = 0; s < 2; ++s) {
      const float sx = s ? -1.0f : 1.0f;
      head.ear_c[s] = V3(sx * 7.25f * fw, -0.3f, -0.9f);
      head.concha_c[s] = V3(sx * (7.25f * fw + 1.05f), -0.1f, -0.7f);
    }
    head.ear_r = V3(1.0f, 2.6f, 1.7f);
    head.concha_r = V3(0.55f, 1.5f, 0.95f);
    head.features = true;
    f.nose_tip = head.tip + V3(0, 0, head.tip_r * 1.08f);

    // Nostrils: the nose's underside below each ala.
    nostril_axis = V3(0, 1.0f, -0.45f).normalized();
    for (int s = 0; s < 2; ++s) {
      const V3 start = head.tip + V3(s ? -0.48f : 0.48f, -0.1f, -0.55f);
      nostril_c[s] = head.raycast(start, -nostril_axis);
    }

    // Mouth: the lip line's centre on the base surface, the ray origin behind it.
    const float mouth_height = lower_y(-4.5f);
    f.mouth = head.raycast(V3(0, mouth_height, 0), V3(0, 0, 1));
    ray_origin = V3(0, -1.2f, -0.6f);
    mouth_axis = (f.mouth - ray_origin).normalized();
    f.lip_dir = (mouth_axis + V3(0, 0, 0.6f)).normalized();
    mouth_x = V3(1, 0, 0);
    mouth_y = mouth_axis.cross(mouth_x).normalized();
    proj_f = (f.mouth - ray_origin).norm();
    mouth_c = 2.2f * prm.face_width;
    f.mouth_half_width = mouth_c;
    f.lip_bulge_upper = 0.42f * prm.lip_thickness;
    f.lip_bulge_lower = 0.5f * prm.lip_thickness;
    vermilion_upper = std::asinh(0.72f / mouth_c);
    vermilion_lower = std::asinh(0.85f / mouth_c);
    f.lip_depth = 0.9f;
    cavity_w = 2.8f * prm.face_width;
    cavity_h = 2.1f * std::min(1.0f, prm.jaw_length);
    cavity_y = -0.5f;
    cavity_d = 6.0f;
    f.jaw_hinge = V3(0, -1.6f, 0.3f);

    // Eyes: the eyeball's front sits just in front of the base surface.
    f.eye_radius = 1.45f * prm.eye_size;
    const float R = f.eye_radius;
    for (int s = 0; s < 2; ++s) {
      const float x = (s ? -3.25f : 3.25f) * fw;
      const V3 front = head.raycast(V3(x, 1.5f, 0), V3(0, 0, 1));
      f.eye_center[s] = front + V3(0, 0, 0.2f - R);
      eye_axis[s] = V3(0, 0, 1);
    }
    f.lid_lower_in = R + 0.11f;
    f.lid_lower_out = R + 0.17f;
    f.lid_upper_in = R + 0.22f;
    f.lid_upper_out = R + 0.30f;
    f.socket_radius = R + 0.48f;
    f.upper_margin = deg(25);
    f.lower_margin = deg(20);
    f.corner_angle = deg(44);
    for (int s = 0; s < 2; ++s) {
      const float sx = s ? -1.0f : 1.0f;
      f.brow[s] = V3(f.eye_center[s].x() + sx * 0.25f, f.eye_center[s].y() + R + 1.0f, 0);
      f.brow[s] = head.raycast(V3(f.brow[s].x(), f.brow[s].y(), 0), V3(0, 0, 1));
      f.cheek[s] = head.raycast(V3(sx * 3.4f * fw, lower_y(-2.2f), 0), V3(0, 0, 1));
    }
  }

  // Direction of the outer skin grid point (mu, nu) from the ray origin.
  V3 direction(float mu, float nu) const {
    const float qx = mouth_c * std::cosh(mu + mu0) * std::cos(nu);
    const float qy = mouth_c * std::sinh(mu + mu0) * std::sin(nu);
    const float r = std::hypot(qx, qy);
    const float th = 2.0f * std::atan(r / (2.0f * proj_f));
    return (std::cos(th) * mouth_axis + std::sin(th) * (qx * mouth_x + qy * mouth_y) / r)
        .normalized();
  }

  float lip_profile(float u) const {  // forward bulge of the lips along the ring coordinate
    if (u <= 0.0f) return 0.0f;
    if (u < 0.55f) return std::pow(std::sin(0.5f * kPi * u / 0.55f), 0.6f);
    if (u < 1.4f) return 0.5f * (1.0f + std::cos(kPi * (u - 0.55f) / 0.85f));
    return 0.0f;
  }

  // ---- skin ---------------------------------------------------------------------------------
  void build_skin() {
    const int n = n_around;
    const float dmu = 2.0f * kPi / static_cast<float>(n);
    std::vector<float> mus;
    for (float mu = 0; mu < 3.0f; mu += dmu) mus.push_back(mu);
    const float th_end = deg(176);
    const float th_start =
        2.0f * std::atan(0.5f * mouth_c * std::exp(mus.back() + dmu) / (2 * proj_f));
    constexpr int kBackRings = 28;
    for (int k = 0; k < kBackRings; ++k) {
      const float th = th_start + (th_end - th_start) * static_cast<float>(k) / (kBackRings - 1);
      const float q = 2.0f * proj_f * std::tan(0.5f * th);
      mus.push_back(std::acosh(std::max(q / mouth_c, 1.0f)) - mu0);
    }
    // Inner rings: s values (lip tunnel, then the bag), from the lip line inwards.
    std::vector<float> inner_s;
    const float s_lip = 0.25f;
    for (int j = 1; j <= j_lip; ++j) inner_s.push_back(s_lip * static_cast<float>(j) / j_lip);
    for (int j = 1; j < j_bag; ++j)
      inner_s.push_back(s_lip + (1 - s_lip) * static_cast<float>(j) / j_bag);

    // Outer rings.
    std::vector<std::vector<int>> outer(mus.size(), std::vector<int>(n));
    for (std::size_t k = 0; k < mus.size(); ++k) {
      for (int i = 0; i < n; ++i) {
        const float nu = 2.0f * kPi * static_cast<float>(i) / n;
        VertexInfo vi;
        vi.nu = nu;
        vi.mu = mus[k];
        vi.lip_u = mus[k] / (std::sin(nu) >= 0 ? vermilion_upper : vermilion_lower);
        outer[k][i] = b.add(head.raycast(ray_origin, direction(mus[k], nu)), vi);
      }
    }
    relax_outer(outer);
    // Contact ring in local cavity coordinates, before the lip bulge (it has none).
    std::vector<V3> contact(n);
    for (int i = 0; i < n; ++i) contact[i] = b.pos[outer[0][i]];
    for (auto& ring : outer)
      for (int v : ring) shape_outer(v);

    // Inner rings: from the lip line into the cavity.
    std::vector<std::vector<int>> inner(inner_s.size(), std::vector<int>(n));
    for (std::size_t j = 0; j < inner_s.size(); ++j) {
      for (int i = 0; i < n; ++i) {
        const float nu = 2.0f * kPi * static_cast<float>(i) / n;
        VertexInfo vi;
        vi.inner = true;
        vi.nu = nu;
        vi.s = inner_s[j];
        vi.anchor = contact[i];
        inner[j][i] = b.add(inner_point(contact[i], inner_s[j], s_lip, nu, &vi.inner_att), vi);
      }
    }
    VertexInfo throat_info;
    throat_info.inner = true;
    throat_info.s = 1.0f;
    throat_info.inner_att = 0.0f;
    const int throat = b.add(f.mouth + V3(0, 0, -(f.lip_depth + cavity_d)), throat_info);
    b.info[throat].anchor = b.pos[throat];
    const V3 back_dir = -mouth_axis;
    VertexInfo back_info;
    back_info.mu = mus.back() + 1.0f;
    back_info.lip_u = 100;
    const int back = b.add(head.raycast(ray_origin, back_dir), back_info);

    // Rows from the throat to the back of the head.
    std::vector<std::vector<int>> rows;
    for (auto it = inner.rbegin(); it != inner.rend(); ++it) rows.push_back(*it);
    for (auto& r : outer) rows.push_back(r);
    const std::size_t first = b.tris.size();
    b.fan(throat, rows.front(), kSkinMat, kSkinGroup);
    b.grid(rows, true, kSkinMat, kSkinGroup);
    std::vector<int> last = rows.back();
    std::reverse(last.begin(), last.end());
    b.fan(back, last, kSkinMat, kSkinGroup);
    b.orient_closed(first);
    for (std::size_t t = first; t < b.tris.size(); ++t) skin_material(t);
    for (std::size_t v = 0; v < b.pos.size(); ++v)
      if (b.info[v].part == Part::kSkin && !b.info[v].inner) b.info[v].anchor = b.pos[v];
    jaw_weights();

    // Landmarks.
    landmarks.push_back({"mouth_corner_left", outer[0][0]});
    landmarks.push_back({"mouth_corner_right", outer[0][n / 2]});
    const auto peak = [&](int i, float vm) {
      std::size_t k = 0;
      while (k + 1 < mus.size() && mus[k] < 0.5f * vm) ++k;
      return outer[k][i];
    };
    landmarks.push_back({"upper_lip_center", peak(n / 4, vermilion_upper)});
    landmarks.push_back({"lower_lip_center", peak(3 * n / 4, vermilion_lower)});
  }

  // Tangential relaxation around the nose (where rays from the centre graze the surface),
  // projected back onto the head.
  void relax_outer(const std::vector<std::vector<int>>& outer) {
    const int n = n_around;
    const V3 nose_mid = 0.5f * (head.tip + head.root) + V3(0, -0.8f, 0);
    std::vector<float> w(b.pos.size(), 0.0f);
    for (std::size_t k = 1; k + 1 < outer.size(); ++k)
      for (int i = 0; i < n; ++i) {
        const int v = outer[k][i];
        w[v] = smoothstep(0.45f, 0.75f, b.info[v].mu) *
               smoothstep(4.0f, 2.5f, (b.pos[v] - nose_mid).norm());
      }
    std::vector<V3> next = b.pos;
    for (int it = 0; it < 40; ++it) {
      for (std::size_t k = 1; k + 1 < outer.size(); ++k)
        for (int i = 0; i < n; ++i) {
          const int v = outer[k][i];
          if (w[v] <= 0) continue;
          const V3 avg = 0.25f * (b.pos[outer[k - 1][i]] + b.pos[outer[k + 1][i]] +
                                  b.pos[outer[k][(i + 1) % n]] + b.pos[outer[k][(i + n - 1) % n]]);
          const V3 nrm = head.gradient(b.pos[v]);
          V3 d = avg - b.pos[v];
          d -= d.dot(nrm) * nrm;
          next[v] = head.project(b.pos[v] + 0.5f * w[v] * d);
        }
      for (std::size_t k = 1; k + 1 < outer.size(); ++k)
        for (int i = 0; i < n; ++i) b.pos[outer[k][i]] = next[outer[k][i]];
    }
  }

  // Lip bulge, nostrils, brows and eye sockets on an outer skin vertex.
  void shape_outer(int v) {
    VertexInfo& vi = b.info[v];
    V3 p = b.pos[v];
    // Lips: bulge along the mouth axis (tilted towards +z), thinning to nothing at the corners.
    const bool upper = std::sin(vi.nu) >= 0;
    const float bulge = upper ? f.lip_bulge_upper : f.lip_bulge_lower;
    const float taper = std::pow(std::abs(std::sin(vi.nu)), 0.45f);
    vi.bulge = bulge * taper * lip_profile(vi.lip_u);
    p += f.lip_dir * vi.bulge;
    // Nostrils: pockets pushed up into the nose.
    const V3 side_dir = nostril_axis.cross(V3(1, 0, 0)).normalized();
    for (const auto& c : nostril_c) {
      const V3 d = p - c;
      const float l1 = d.x() / 0.27f, l2 = d.dot(side_dir) / 0.36f;
      const float r2 = l1 * l1 + l2 * l2;
      if (r2 < 1.0f && std::abs(d.dot(nostril_axis)) < 0.5f) {
        const float h = (1.0f - r2);
        p += nostril_axis * 0.55f * h * h;
      }
    }
    // Brows: a raised band.
    for (int s = 0; s < 2; ++s) {
      const float bw = brow_weight(p, s);
      if (bw > 0) p += head.gradient(b.pos[v]) * 0.12f * bw;
    }
    // Eye sockets: inside the rim the skin folds back into a bowl behind the eyeball; the rim is an
    // ellipse (wider than tall).
    for (int s = 0; s < 2; ++s) {
      const V3 d = p - f.eye_center[s];
      const float along = d.dot(eye_axis[s]);
      const V3 lat = d - along * eye_axis[s];
      const float rho = lat.norm();
      const V3 dir = rho > 1e-6f ? V3(lat / rho) : V3(1, 0, 0);
      const float beta = 1.0f / std::hypot(dir.x() / rim_wide, dir.y() / rim_tall);
      const float rim_r = f.socket_radius;
      const float rim_lat = rim_r * std::sin(beta), rim_fwd = rim_r * std::cos(beta);
      const float rho_rim = 1.2f * rim_lat, rho_out = rho_rim + 0.85f;
      if (along <= 0 || rho >= rho_out) continue;
      const float r = rho;
      if (r < rho_rim) {
        const float psi = kPi - (kPi - beta) * std::pow(r / rho_rim, 0.6f);  // denser at the rim
        const float rb = rim_r + 0.45f * smoothstep(1.66f, 2.4f, psi);  // roomier behind the eye
        p = f.eye_center[s] + rb * (std::cos(psi) * eye_axis[s] + std::sin(psi) * dir);
        vi.eye_mask = 0;
      } else {
        const float t = (r - rho_rim) / (rho_out - rho_rim);
        const float lat_r = rim_lat + (rho - rim_lat) * t;
        const float fwd =
            rim_fwd + (along - rim_fwd) * smoothstep(0.0f, 1.0f, t) + 0.1f * std::sin(kPi * t);
        p = f.eye_center[s] + fwd * eye_axis[s] + lat_r * dir;
        vi.eye_mask = std::min(vi.eye_mask, smoothstep(0.1f, 1.0f, t));
      }
    }
    b.pos[v] = p;
  }

  float brow_weight(const V3& p, int s) const {
    const float sx = s ? -1.0f : 1.0f;
    const float u = sx * (p.x() - f.brow[s].x()) / (2.0f * prm.face_width);  // -1 inner .. 1 outer
    if (std::abs(u) >= 1.0f) return 0.0f;
    const float centre_y = f.brow[s].y() - 0.35f * u * u + 0.05f * u;
    const float half = 0.32f * (1.0f - 0.45f * u) * std::sqrt(1.0f - u * u);
    const float v = std::abs(p.y() - centre_y) / std::max(half, 1e-3f);
    if (p.z() < f.eye_center[s].z()) return 0.0f;
    return smoothstep(1.15f, 0.75f, v) * smoothstep(1.0f, 0.85f, std::abs(u));
  }

  // Inner skin: the inner lips (a short tunnel from the lip line) and the cavity (a bag).
  static constexpr float kArch = 0.15f;  // the cavity's front curves back like the dental arch

  V3 inner_point(const V3& contact, float s, float s_lip, float nu, float* att) const {
    const float cn = std::cos(nu), sn = std::sin(nu);
    const auto sq = [](float v) { return std::copysign(std::sqrt(std::abs(v)), v); };
    const float x0 = mouth_c * std::cosh(mu0), y0 = mouth_c * std::sinh(mu0);
    const float d_lip = f.lip_depth;
    // The ideal cross-section at the end of the tunnel (a rounded rectangle).
    const float x_end = 0.94f * x0, y_end = tunnel_open;
    if (s <= s_lip) {
      const float u = s / s_lip;
      const V3 c = contact - f.mouth;
      const float y_open = y0 + (tunnel_open - y0) * u * u;
      const V3 rel(c.x() * (1.0f - 0.06f * u), c.y() + (y_open - y0) * sn, c.z() * (1.0f - u));
      const V3 ideal(x_end * sq(cn), y_end * sq(sn), 0);
      const float blend = u * u;
      V3 q = (1 - blend) * rel + blend * ideal;
      q.z() = c.z() * (1.0f - u) - d_lip * u - kArch * q.x() * q.x() * u * u;
      *att = 1.0f - 0.35f * u;
      return f.mouth + q;
    }
    const float tau = kPi * (s - s_lip) / (1.0f - s_lip);
    const float k = std::sqrt(std::max(std::sin(tau), 0.0f));
    const float fade = 1.0f - tau / kPi;
    const float X = x_end * fade + (cavity_w - x_end * fade) * k;
    const float H = 1.45f + (cavity_h - 1.45f) * smoothstep(0.0f, 1.2f, tau);
    const float Y = y_end * fade + (H - y_end * fade) * k;
    const float x = X * sq(cn);
    const float depth = d_lip + 0.5f * cavity_d * (1.0f - std::cos(tau)) + kArch * x * x;
    *att = 0.65f * smoothstep(1.2f, 0.0f, tau);
    return f.mouth + V3(x, cavity_y * k * smoothstep(0.3f, 1.5f, tau) + Y * sq(sn), -depth);
  }

  void skin_material(std::size_t t) {
    const auto& tr = b.tris[t];
    const VertexInfo& a = b.info[tr[0]];
    const VertexInfo& c = b.info[tr[1]];
    const VertexInfo& d = b.info[tr[2]];
    const V3 centroid = (b.pos[tr[0]] + b.pos[tr[1]] + b.pos[tr[2]]) / 3.0f;
    const float sn = std::sin(a.nu) + std::sin(c.nu) + std::sin(d.nu);
    const bool all_inner = a.inner && c.inner && d.inner;
    const float max_s = std::max({a.s, c.s, d.s});
    const float max_u =
        std::max({a.inner ? 0 : a.lip_u, c.inner ? 0 : c.lip_u, d.inner ? 0 : d.lip_u});
    int m = kSkinMat;
    if (all_inner && max_s > 0.25f) {
      m = kMouthMat;
    } else if (max_u <= 1.0f || (a.inner || c.inner || d.inner)) {
      m = kLipsMat;
    }
    for (int s = 0; s < 2 && m == kSkinMat; ++s)
      if (brow_weight(centroid, s) > 0.5f) m = kBrowMat;
    for (const auto& nc : nostril_c)
      if ((centroid - nc).dot(nostril_axis) > 0.14f && (centroid - nc).norm() < 0.7f) m = kMouthMat;
    b.mat[t] = m;
    // Touching lips: the lip line's bands on both layers.
    const bool band = (a.inner || a.mu < 0.1f) && (c.inner || c.mu < 0.1f) &&
                      (d.inner || d.mu < 0.1f) && max_s <= 0.25f + 1e-4f;
    if (band) b.group[t] = sn >= 0 ? kLipUpper : kLipLower;
  }

  void jaw_weights() {
    const V3 J = f.jaw_hinge;
    const float th_m = std::atan2(f.mouth.y() - J.y(), f.mouth.z() - J.z());
    const float th_neck = deg(-118);
    for (std::size_t v = 0; v < b.pos.size(); ++v) {
      VertexInfo& vi = b.info[v];
      if (vi.part != Part::kSkin) continue;
      const float sn = std::sin(vi.nu);
      const float w_lip = smoothstep(0.3f, -0.3f, sn);
      if (vi.inner) {
        vi.jaw = w_lip;
        continue;
      }
      const V3 d = b.pos[v] - J;
      const float th = std::atan2(d.y(), d.z());
      const float r = std::hypot(d.y(), d.z());
      float w = smoothstep(th_m + deg(9), th_m - deg(9), th) *
                smoothstep(th_neck - deg(25), th_neck + deg(25), th) * smoothstep(1.0f, 3.5f, r);
      if (d.z() < -2.0f) w *= smoothstep(-5.0f, -2.0f, d.z());
      const float blend = smoothstep(0.35f, 0.95f, vi.mu);
      vi.jaw = (1 - blend) * w_lip + blend * w;
    }
  }

  // ---- teeth --------------------------------------------------------------------------------
  void build_teeth(bool upper) {
    const float fw = prm.face_width;
    const float ax = (upper ? 1.9f : 1.5f) * fw, az = upper ? 2.7f : 2.35f;
    const float z_front = -(f.lip_depth + (upper ? 0.42f : 0.86f));
    const float phi_max = deg(98);
    constexpr int kArchSamples = 72, kSection = 14;
    const float th0 = upper ? 0.32f : 0.26f, th1 = upper ? 0.72f : 0.6f;
    std::vector<std::vector<int>> rows;
    double arc = 0;
    V3 prev_c(0, 0, 0);
    const Part part = upper ? Part::kTeethUpper : Part::kTeethLower;
    std::vector<V3> centres;
    for (int i = 0; i < kArchSamples; ++i) {
      const float phi = -phi_max + 2.0f * phi_max * static_cast<float>(i) / (kArchSamples - 1);
      const float t = std::abs(phi) / phi_max;
      const V3 c(ax * std::sin(phi), 0, z_front - az * (1 - std::cos(phi)));
      if (i) arc += (c - prev_c).norm();
      prev_c = c;
      const V3 tangent = V3(ax * std::cos(phi), 0, -az * std::sin(phi)).normalized();
      const V3 out(-tangent.z(), 0, tangent.x());
      const float th = th0 + (th1 - th0) * t * t;
      const float step = smoothstep(0.12f, 0.5f, t);
      const float y_lo = upper ? -0.3f + 0.4f * step : -1.05f;
      const float y_hi = upper ? 1.0f : -0.02f - 0.12f * step;
      // Grooves between teeth: narrower and shorter at tooth boundaries.
      const float tooth_w = 0.78f + 0.25f * t;
      const float g = std::pow(std::abs(std::sin(kPi * static_cast<float>(arc) / tooth_w)), 0.6f);
      const float groove = 0.8f + 0.2f * g;
      std::vector<int> row(kSection);
      for (int k = 0; k < kSection; ++k) {
        const float w = 2.0f * kPi * static_cast<float>(k) / kSection;
        const float cw = std::cos(w), sw = std::sin(w);
        const float n =
            0.5f * th * std::copysign(std::sqrt(std::abs(cw)), cw) * (cw > 0 ? groove : 1.0f);
        float hy = 0.5f * (y_hi - y_lo);
        const float ym = 0.5f * (y_hi + y_lo);
        const bool edge = upper ? sw < 0 : sw > 0;  // the biting edge
        if (edge) hy *= 0.94f + 0.06f * g;
        const float y = ym + hy * std::copysign(std::sqrt(std::abs(sw)), sw);
        VertexInfo vi;
        vi.part = part;
        row[k] = b.add(f.mouth + c + n * out + V3(0, y, 0), vi);
      }
      rows.push_back(row);
      centres.push_back(f.mouth + c + V3(0, 0.5f * (y_hi + y_lo), 0));
    }
    const std::size_t first = b.tris.size();
    const int g = upper ? kTeethUpperGroup : kTeethLowerGroup;
    b.grid(rows, true, kTeethMat, g);
    VertexInfo vi;
    vi.part = part;
    const int c0 = b.add(centres.front(), vi);
    const int c1 = b.add(centres.back(), vi);
    b.fan(c0, rows.front(), kTeethMat, g);
    std::vector<int> last = rows.back();
    std::reverse(last.begin(), last.end());
    b.fan(c1, last, kTeethMat, g);
    b.orient_closed(first);
  }

  // ---- tongue -------------------------------------------------------------------------------
  void build_tongue() {
    const V3 root = f.mouth + V3(0, -0.95f, -(f.lip_depth + 5.2f));
    const V3 tip = f.mouth + V3(0, -0.8f, -(f.lip_depth + 1.4f));
    for (int i = 0; i <= 16; ++i) {
      const float t = static_cast<float>(i) / 16;
      f.tongue_line.push_back(root + t * (tip - root) + V3(0, 0.18f * std::sin(kPi * t), 0));
    }
    // Tongue out (relative to the jaw): up over the lower incisors, then out between the lips.
    const float d = f.lip_depth;
    const std::array<V3, 5> ctrl{f.mouth + V3(0, -0.9f, -(d + 4.2f)),
                                 f.mouth + V3(0, -0.3f, -(d + 2.4f)),
                                 f.mouth + V3(0, 0.65f, -(d + 0.9f)), f.mouth + V3(0, 0.5f, -0.1f),
                                 f.mouth + V3(0, 0.25f, 1.0f)};
    for (std::size_t seg = 0; seg + 1 < ctrl.size(); ++seg) {  // Catmull-Rom through ctrl
      const V3 p0 = ctrl[seg ? seg - 1 : 0], p1 = ctrl[seg], p2 = ctrl[seg + 1];
      const V3 p3 = ctrl[std::min(seg + 2, ctrl.size() - 1)];
      for (int i = 0; i < 8; ++i) {
        const float t = static_cast<float>(i) / 8, t2 = t * t, t3 = t2 * t;
        f.tongue_out_line.push_back(0.5f * (2 * p1 + (-p0 + p2) * t +
                                            (2 * p0 - 5 * p1 + 4 * p2 - p3) * t2 +
                                            (-p0 + 3 * p1 - 3 * p2 + p3) * t3));
      }
    }
    f.tongue_out_line.push_back(ctrl.back());

    constexpr int kAlong = 26, kAround = 24;
    const float half_w = 0.95f * prm.face_width, half_h = 0.55f;
    std::vector<std::vector<int>> rows;
    for (int i = 1; i < kAlong; ++i) {
      const float t = static_cast<float>(i) / kAlong;
      // Rounded root and tip: a blunt tip, a longer taper at the root.
      const float scale = std::sqrt(std::max(0.0f, 1.0f - std::pow(2.0f * t - 1.0f, 6.0f))) *
                          (0.75f + 0.25f * smoothstep(0.0f, 0.6f, t));
      std::vector<int> row(kAround);
      for (int k = 0; k < kAround; ++k) {
        const float w = 2.0f * kPi * static_cast<float>(k) / kAround;
        const float cw = std::cos(w), sw = std::sin(w);
        float x = half_w * scale * std::copysign(std::pow(std::abs(cw), 0.7f), cw);
        float y = half_h * scale * std::copysign(std::pow(std::abs(sw), 0.8f), sw);
        if (sw > 0) y -= 0.07f * scale * std::exp(-x * x / 0.12f);  // median groove
        VertexInfo vi;
        vi.part = Part::kTongue;
        vi.along = t;
        vi.cross = Eigen::Vector2f(x, y);
        row[k] = b.add(polyline_at(f.tongue_line, t) + V3(x, y, 0), vi);
      }
      rows.push_back(row);
    }
    const std::size_t first = b.tris.size();
    b.grid(rows, true, kTongueMat, kTongueGroup);
    VertexInfo r0;
    r0.part = Part::kTongue;
    r0.along = 0;
    VertexInfo r1 = r0;
    r1.along = 1;
    const int p0 = b.add(polyline_at(f.tongue_line, 0), r0);
    const int p1 = b.add(polyline_at(f.tongue_line, 1), r1);
    b.fan(p0, rows.front(), kTongueMat, kTongueGroup);
    std::vector<int> last = rows.back();
    std::reverse(last.begin(), last.end());
    b.fan(p1, last, kTongueMat, kTongueGroup);
    b.orient_closed(first);
  }

  // ---- eyes ---------------------------------------------------------------------------------
  void build_eyeball(int side) {
    const V3 C = f.eye_center[side];
    const float R = f.eye_radius;
    std::vector<float> polar{0.07f, 0.14f, 0.21f, 0.28f, 0.36f, 0.44f, 0.52f};
    constexpr int kBack = 18;
    for (int i = 1; i <= kBack; ++i)
      polar.push_back(0.52f + (kPi - 0.12f - 0.52f) * static_cast<float>(i) / kBack);
    constexpr int kAround = 36;
    VertexInfo vi;
    vi.part = Part::kEyeball;
    vi.side = side;
    std::vector<std::vector<int>> rows;
    for (float th : polar) {
      std::vector<int> row(kAround);
      for (int k = 0; k < kAround; ++k) {
        const float w = 2.0f * kPi * static_cast<float>(k) / kAround;
        row[k] = b.add(
            C + R * V3(std::sin(th) * std::cos(w), std::sin(th) * std::sin(w), std::cos(th)), vi);
      }
      rows.push_back(row);
    }
    const int g = side ? kEyeballRight : kEyeballLeft;
    const std::size_t first = b.tris.size();
    const int front = b.add(C + V3(0, 0, R), vi);
    const int back = b.add(C - V3(0, 0, R), vi);
    b.fan(front, rows.front(), kPupilMat, g);
    b.grid(rows, true, kScleraMat, g);
    std::vector<int> last = rows.back();
    std::reverse(last.begin(), last.end());
    b.fan(back, last, kScleraMat, g);
    b.orient_closed(first);
    for (std::size_t t = first; t < b.tris.size(); ++t) {
      const auto& tr = b.tris[t];
      const V3 c = (b.pos[tr[0]] + b.pos[tr[1]] + b.pos[tr[2]]) / 3.0f - C;
      const float th = std::acos(std::clamp(c.normalized().z(), -1.0f, 1.0f));
      b.mat[t] = th < 0.21f ? kPupilMat : th < 0.52f ? kIrisMat : kScleraMat;
    }
    landmarks.push_back({side ? "pupil_right" : "pupil_left", front});
  }

  float margin_elevation(bool upper, float a) const {
    const float q = (a / f.corner_angle) * (a / f.corner_angle);
    constexpr float kOverlap = deg(4);
    return upper ? f.upper_margin - (f.upper_margin + kOverlap) * q
                 : -f.lower_margin + (f.lower_margin + kOverlap) * q;
  }

  void build_lid(int side, bool upper) {
    const V3 C = f.eye_center[side];
    const float r_in = upper ? f.lid_upper_in : f.lid_lower_in;
    const float r_out = upper ? f.lid_upper_out : f.lid_lower_out;
    const float r_mid = 0.5f * (r_in + r_out), half_t = 0.5f * (r_out - r_in);
    const float e_far = upper ? deg(80) : deg(-80);
    const float a_max = deg(62);
    constexpr int kLateral = 36, kSheet = 8, kRound = 4;
    const float sgn = upper ? -1.0f : 1.0f;  // direction from the margin towards the opening
    const auto dir = [](float a, float e) {
      return V3(std::sin(a), std::cos(a) * std::sin(e), std::cos(a) * std::cos(e));
    };
    std::vector<std::vector<int>> rows;  // one row per loop position, columns = lateral
    std::vector<std::vector<std::pair<float, float>>> loop(kLateral);  // (r, e) per loop position
    const Part part = upper ? Part::kLidUpper : Part::kLidLower;
    for (int j = 0; j < kLateral; ++j) {
      const float a = -a_max + 2.0f * a_max * static_cast<float>(j) / (kLateral - 1);
      const float em = margin_elevation(upper, a);
      auto& L = loop[j];
      for (int i = 0; i < kSheet; ++i) {  // inner sheet, far edge -> margin
        const float t = 1.0f - static_cast<float>(i) / (kSheet - 1);
        L.emplace_back(r_in, em + (e_far - em) * std::pow(t, 1.5f));
      }
      for (int i = 1; i <= kRound; ++i) {  // rounded margin
        const float k = kPi * static_cast<float>(i) / (kRound + 1);
        L.emplace_back(r_mid - half_t * std::cos(k),
                       em + sgn * 1.3f * half_t * std::sin(k) / r_mid);
      }
      for (int i = 0; i < kSheet; ++i) {  // outer sheet, margin -> far edge
        const float t = static_cast<float>(i) / (kSheet - 1);
        L.emplace_back(r_out, em + (e_far - em) * std::pow(t, 1.5f));
      }
    }
    const std::size_t n_loop = loop[0].size();
    for (std::size_t i = 0; i < n_loop; ++i) {
      std::vector<int> row(kLateral);
      for (int j = 0; j < kLateral; ++j) {
        const float a = -a_max + 2.0f * a_max * static_cast<float>(j) / (kLateral - 1);
        const auto [r, e] = loop[j][i];
        VertexInfo vi;
        vi.part = part;
        vi.side = side;
        vi.a = a;
        vi.e = e;
        vi.mu = static_cast<float>(i);  // loop position (used for lash colouring)
        row[j] = b.add(C + r * dir(a, e), vi);
      }
      rows.push_back(row);
    }
    const int g =
        side ? (upper ? kLidUpperRight : kLidLowerRight) : (upper ? kLidUpperLeft : kLidLowerLeft);
    const std::size_t first = b.tris.size();
    b.grid(rows, false, kSkinMat, g);
    // The outer sheet faces away from the eye centre.
    const std::size_t probe = b.tris.size() - 2;
    const auto& pt = b.tris[probe];
    b.orient_open(first, probe, (b.pos[pt[0]] - C));
    if (upper) {
      for (std::size_t t = first; t < b.tris.size(); ++t) {
        const auto& tr = b.tris[t];
        float lo = 1e9f;
        for (int c = 0; c < 3; ++c) lo = std::min(lo, b.info[tr[c]].mu);
        if (lo >= kSheet - 1 && lo <= kSheet + kRound) b.mat[t] = kLashMat;
      }
    }
    if (upper) {
      const int mid = kSheet + kRound / 2;
      const float a_c = f.corner_angle;
      const int jc = static_cast<int>(std::lround((a_c + a_max) / (2 * a_max) * (kLateral - 1)));
      const int jc2 = kLateral - 1 - jc;
      // Left eye (+x): outer corner at +a.
      landmarks.push_back({std::string("eye_outer_corner_") + (side ? "right" : "left"),
                           rows[mid][side ? jc2 : jc]});
      landmarks.push_back({std::string("eye_inner_corner_") + (side ? "right" : "left"),
                           rows[mid][side ? jc : jc2]});
    }
  }

  std::vector<Landmark> landmarks;
};

}  // namespace

Eigen::Vector3f polyline_at(const std::vector<Eigen::Vector3f>& line, float t) {
  double total = 0;
  for (std::size_t i = 1; i < line.size(); ++i) total += (line[i] - line[i - 1]).norm();
  double want = std::clamp(t, 0.0f, 1.0f) * total;
  for (std::size_t i = 1; i < line.size(); ++i) {
    const double len = (line[i] - line[i - 1]).norm();
    if (want <= len || i + 1 == line.size()) {
      const float u = len > 0 ? static_cast<float>(std::min(want / len, 1.0)) : 0.0f;
      return line[i - 1] + u * (line[i] - line[i - 1]);
    }
    want -= len;
  }
  return line.back();
}

Model build_geometry(const AvatarParams& params) {
  Generator g(params);
  g.setup_head();
  g.build_skin();
  g.build_teeth(true);
  g.build_teeth(false);
  g.build_tongue();
  for (int s = 0; s < 2; ++s) {
    g.build_eyeball(s);
    g.build_lid(s, false);
    g.build_lid(s, true);
  }

  Model m;
  m.params = params;
  m.f = g.f;
  const auto& b = g.b;
  m.pos.resize(static_cast<Eigen::Index>(b.pos.size()), 3);
  for (std::size_t v = 0; v < b.pos.size(); ++v)
    m.pos.row(static_cast<Eigen::Index>(v)) = b.pos[v].transpose();
  m.info = b.info;
  m.tris.resize(static_cast<Eigen::Index>(b.tris.size()), 3);
  for (std::size_t t = 0; t < b.tris.size(); ++t)
    m.tris.row(static_cast<Eigen::Index>(t)) = b.tris[t].transpose();
  m.material = b.mat;
  m.group = b.group;
  m.group_names = {"skin",           "lip_upper",      "lip_lower",       "teeth_upper",
                   "teeth_lower",    "tongue",         "eyeball_left",    "eyeball_right",
                   "lid_upper_left", "lid_lower_left", "lid_upper_right", "lid_lower_right"};
  const auto srgb = [](float r, float gg, float bb) {
    const auto lin = [](float c) {
      c /= 255.0f;
      return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
    };
    return Eigen::Vector4f(lin(r), lin(gg), lin(bb), 1.0f);
  };
  m.materials = {{"M_Skin", srgb(236, 188, 158)},       {"M_Lips", srgb(204, 104, 104)},
                 {"M_MouthInterior", srgb(74, 18, 24)}, {"M_Teeth", srgb(246, 242, 230)},
                 {"M_Tongue", srgb(214, 102, 108)},     {"M_Sclera", srgb(248, 248, 244)},
                 {"M_Iris", srgb(66, 128, 150)},        {"M_Pupil", srgb(8, 8, 10)},
                 {"M_Brows", srgb(96, 64, 44)},         {"M_Lashes", srgb(44, 30, 26)}};
  // Landmarks found by position.
  int nose = -1, chin = -1;
  for (Eigen::Index v = 0; v < m.pos.rows(); ++v) {
    if (m.info[v].part != Part::kSkin || m.info[v].inner) continue;
    if (nose < 0 || m.pos(v, 2) > m.pos(nose, 2)) nose = static_cast<int>(v);
    if (std::abs(m.pos(v, 0)) < 0.3f && m.pos(v, 2) > 3.0f &&
        (chin < 0 || m.pos(v, 1) < m.pos(chin, 1)))
      chin = static_cast<int>(v);
  }
  m.landmarks = g.landmarks;
  m.landmarks.push_back({"nose_tip", nose});
  m.landmarks.push_back({"chin", chin});
  return m;
}

}  // namespace facecast::anim::avatar_detail
