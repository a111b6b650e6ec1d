// The default avatar's teeth (two closed arches with grooves between the teeth) and tongue (a
// closed tube along a centre line, with its tongue-out line for the tongueOut shape).
#include <algorithm>
#include <array>
#include <cmath>

#include "generator.hpp"

namespace facecast::avatar::detail {

void Generator::build_teeth(bool upper) {
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
  b.fan_end(c1, rows.back(), kTeethMat, g);
  b.orient_closed(first);
}

void Generator::build_tongue() {
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
      f.tongue_out_line.push_back(0.5f *
                                  (2 * p1 + (-p0 + p2) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t2 +
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
  b.fan_end(p1, rows.back(), kTongueMat, kTongueGroup);
  b.orient_closed(first);
}

}  // namespace facecast::avatar::detail
