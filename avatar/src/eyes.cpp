// The default avatar's eyeballs (spheres with iris and pupil materials) and eyelids (sheets on
// spheres around the eyeball, with a rounded margin; the upper lids carry the lashes).
#include <algorithm>
#include <cmath>
#include <string>

#include "generator.hpp"

namespace facecast::avatar::detail {

float margin_elevation(const Frames& f, bool upper, float a) {
  const float q = (a / f.corner_angle) * (a / f.corner_angle);
  constexpr float kOverlap = deg(4);
  return upper ? f.upper_margin - (f.upper_margin + kOverlap) * q
               : -f.lower_margin + (f.lower_margin + kOverlap) * q;
}

void Generator::build_eyeball(int side) {
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
  b.fan_end(back, rows.back(), kScleraMat, g);
  b.orient_closed(first);
  for (std::size_t t = first; t < b.tris.size(); ++t) {
    const auto& tr = b.tris[t];
    const V3 c = (b.pos[tr[0]] + b.pos[tr[1]] + b.pos[tr[2]]) / 3.0f - C;
    const float th = std::acos(std::clamp(c.normalized().z(), -1.0f, 1.0f));
    b.mat[t] = th < 0.21f ? kPupilMat : th < 0.52f ? kIrisMat : kScleraMat;
  }
  landmarks.push_back({side ? "pupil_right" : "pupil_left", front});
}

void Generator::build_lid(int side, bool upper) {
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
    const float em = margin_elevation(f, upper, a);
    auto& L = loop[j];
    for (int i = 0; i < kSheet; ++i) {  // inner sheet, far edge -> margin
      const float t = 1.0f - static_cast<float>(i) / (kSheet - 1);
      L.emplace_back(r_in, em + (e_far - em) * std::pow(t, 1.5f));
    }
    for (int i = 1; i <= kRound; ++i) {  // rounded margin
      const float k = kPi * static_cast<float>(i) / (kRound + 1);
      L.emplace_back(r_mid - half_t * std::cos(k), em + sgn * 1.3f * half_t * std::sin(k) / r_mid);
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
    landmarks.push_back(
        {std::string("eye_outer_corner_") + (side ? "right" : "left"), rows[mid][side ? jc2 : jc]});
    landmarks.push_back(
        {std::string("eye_inner_corner_") + (side ? "right" : "left"), rows[mid][side ? jc : jc2]});
  }
}

}  // namespace facecast::avatar::detail
