// The default avatar's skin: one closed surface, the head folded into lips, a mouth cavity and eye
// sockets.
//
// The skin is a grid of rings around the mouth. Outside the lip line the rings are elliptic
// coordinates (x, y) = c (cosh(mu + mu0) cos nu, sinh(mu + mu0) sin nu): at mu = 0 they are the lip
// line itself, a slit whose upper and lower edges are 2 c sinh(mu0) apart (the lips meet). The
// plane is mapped conformally onto directions around the mouth axis (stereographic projection) and
// each direction is ray-cast from a point inside the head onto the head's signed-distance model.
// Inside the lip line the same rings continue as the inner lips and then a closed bag, the mouth
// cavity, ending in a pole at the throat. Around each eye the surface is folded back into a
// socket: a bowl behind the eyeball.
#include <algorithm>
#include <cmath>

#include "generator.hpp"

namespace facecast::avatar::detail {

void Generator::build_skin() {
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
  const auto outer = skin_rings(mus.size(), [&](std::size_t k, int, VertexInfo& vi) {
    vi.mu = mus[k];
    vi.lip_u = mus[k] / (std::sin(vi.nu) >= 0 ? vermilion_upper : vermilion_lower);
    return head.raycast(ray_origin, direction(mus[k], vi.nu));
  });
  relax_outer(outer);
  // Contact ring in local cavity coordinates, before the lip bulge (it has none).
  std::vector<V3> contact(n);
  for (int i = 0; i < n; ++i) contact[i] = b.pos[outer[0][i]];
  for (auto& ring : outer)
    for (int v : ring) shape_outer(v);

  // Inner rings: from the lip line into the cavity.
  const auto inner = skin_rings(inner_s.size(), [&](std::size_t j, int i, VertexInfo& vi) {
    vi.inner = true;
    vi.s = inner_s[j];
    vi.anchor = contact[i];
    return inner_point(contact[i], inner_s[j], s_lip, vi.nu, &vi.inner_att);
  });
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
  b.fan_end(back, rows.back(), kSkinMat, kSkinGroup);
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

// `count` rings of n_around vertices around the mouth axis; vertex i of a ring is at the angle
// nu = 2 pi i / n_around (0 = the left mouth corner, pi/2 = the upper lip's centre). `place` fills
// the vertex's information (nu is set) and returns its position.
std::vector<std::vector<int>> Generator::skin_rings(
    std::size_t count, const std::function<V3(std::size_t ring, int i, VertexInfo& vi)>& place) {
  const int n = n_around;
  std::vector<std::vector<int>> rings(count, std::vector<int>(n));
  for (std::size_t k = 0; k < count; ++k) {
    for (int i = 0; i < n; ++i) {
      VertexInfo vi;
      vi.nu = 2.0f * kPi * static_cast<float>(i) / n;
      const V3 p = place(k, i, vi);
      rings[k][i] = b.add(p, vi);
    }
  }
  return rings;
}

// Direction of the outer skin grid point (mu, nu) from the ray origin.
V3 Generator::direction(float mu, float nu) const {
  const float qx = mouth_c * std::cosh(mu + mu0) * std::cos(nu);
  const float qy = mouth_c * std::sinh(mu + mu0) * std::sin(nu);
  const float r = std::hypot(qx, qy);
  const float th = 2.0f * std::atan(r / (2.0f * proj_f));
  return (std::cos(th) * mouth_axis + std::sin(th) * (qx * mouth_x + qy * mouth_y) / r)
      .normalized();
}

// The forward bulge of the lips along the ring coordinate u = mu / vermilion extent.
float Generator::lip_profile(float u) const {
  if (u <= 0.0f) return 0.0f;
  if (u < 0.55f) return std::pow(std::sin(0.5f * kPi * u / 0.55f), 0.6f);
  if (u < 1.4f) return 0.5f * (1.0f + std::cos(kPi * (u - 0.55f) / 0.85f));
  return 0.0f;
}

// Tangential relaxation around the nose (where rays from the centre graze the surface),
// projected back onto the head.
void Generator::relax_outer(const std::vector<std::vector<int>>& outer) {
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
void Generator::shape_outer(int v) {
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
      const float rb = rim_r + 0.45f * smoothstep(1.66f, 2.4f, psi);       // roomier behind the eye
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

float Generator::brow_weight(const V3& p, int s) const {
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
V3 Generator::inner_point(const V3& contact, float s, float s_lip, float nu, float* att) const {
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

void Generator::skin_material(std::size_t t) {
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
  for (const auto& nc : nostril_c)
    if ((centroid - nc).dot(nostril_axis) > 0.14f && (centroid - nc).norm() < 0.7f) m = kMouthMat;
  b.mat[t] = m;
  // Touching lips: the lip line's bands on both layers.
  const bool band = (a.inner || a.mu < 0.1f) && (c.inner || c.mu < 0.1f) &&
                    (d.inner || d.mu < 0.1f) && max_s <= 0.25f + 1e-4f;
  if (band) b.group[t] = sn >= 0 ? kLipUpper : kLipLower;
}

void Generator::jaw_weights() {
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

}  // namespace facecast::avatar::detail
