// The default avatar's blendshapes: rotations about joints (jaw hinge, eye centres) with region
// weights, and smooth displacement fields over the skin, all evaluated on the neutral.
//
// Mouth fields are evaluated at a skin vertex's anchor: its own neutral position outside the lip
// line, the lip-line point of its ring inside (so inner lips move with the outer lips) and fade
// out into the cavity. Eyelids only ever rotate about the eye centre, so they stay on their
// spheres outside the eyeball; skin is kept outside the eye sockets' bowls.
#include <cmath>
#include <functional>
#include <numbers>

#include "model.hpp"

namespace facecast::avatar::detail {
namespace {

const V3 kX(1, 0, 0), kY(0, 1, 0);

constexpr float kJawOpen = deg(20);

struct Ctx {
  const Model& m;
  const Frames& f;
  explicit Ctx(const Model& model) : m(model), f(model.f) {}

  V3 p(int v) const { return m.pos.row(v).transpose(); }
  const VertexInfo& info(int v) const { return m.info[static_cast<std::size_t>(v)]; }

  // Anchor in mouth-plane coordinates (x right, y up, relative to the lip line's centre).
  Eigen::Vector2f mp(const VertexInfo& vi) const {
    const V3 d = vi.anchor - f.mouth;
    return {d.x(), d.y()};
  }
  // 1 on the front of the face, 0 towards the back of the head.
  float front(const VertexInfo& vi) const {
    return smoothstep(f.mouth.z() - 6.5f, f.mouth.z() - 4.0f, vi.anchor.z());
  }
  // Around the mouth (lips, philtrum, chin top), elliptical falloff.
  float mouth_area(const VertexInfo& vi, float up = 1.6f, float down = 2.2f) const {
    const auto q = mp(vi);
    const float ex = q.x() / (f.mouth_half_width + 1.2f), ey = q.y() / (q.y() > 0 ? up : down);
    return smoothstep(1.5f, 0.6f, std::hypot(ex, ey)) * front(vi);
  }
  // The lips themselves (both layers).
  float lips(const VertexInfo& vi) const {
    return vi.inner ? 1.0f : smoothstep(2.2f, 1.0f, vi.lip_u);
  }
  float upper(const VertexInfo& vi) const { return smoothstep(-0.25f, 0.25f, std::sin(vi.nu)); }
  float lower(const VertexInfo& vi) const { return 1.0f - upper(vi); }
  // Gaussian around the mouth corner of `side` (0 = left, +x).
  float corner(const VertexInfo& vi, int side, float sigma) const {
    const auto q = mp(vi);
    const float cx = side ? -f.mouth_half_width : f.mouth_half_width;
    const float d2 = (q.x() - cx) * (q.x() - cx) + q.y() * q.y();
    return std::exp(-d2 / (2 * sigma * sigma)) * front(vi);
  }
  float gauss(const V3& at, const V3& centre, float sx, float sy) const {
    const float dx = (at.x() - centre.x()) / sx, dy = (at.y() - centre.y()) / sy;
    return std::exp(-0.5f * (dx * dx + dy * dy));
  }
  float eye_front(const VertexInfo& vi, int side) const {
    return smoothstep(f.eye_center[side].z() - 2.0f, f.eye_center[side].z() - 0.5f, vi.anchor.z());
  }
};

float side_sign(int side) {
  return side ? -1.0f : 1.0f;
}

using SkinField = std::function<V3(const Ctx&, int v, const VertexInfo&)>;

// Applies a displacement field to the skin (attenuated into the cavity and in the eye sockets)
// and keeps the skin outside the eye sockets' bowls.
void displace_skin(const Ctx& c, rig::Positions& out, const SkinField& field) {
  for (Eigen::Index v = 0; v < out.rows(); ++v) {
    const VertexInfo& vi = c.info(static_cast<int>(v));
    if (vi.part != Part::kSkin) continue;
    const V3 d = field(c, static_cast<int>(v), vi) * (vi.inner_att * vi.eye_mask);
    out.row(v) += d.transpose();
  }
}

void keep_out_of_sockets(const Ctx& c, rig::Positions& out) {
  for (Eigen::Index v = 0; v < out.rows(); ++v) {
    const VertexInfo& vi = c.info(static_cast<int>(v));
    if (vi.part != Part::kSkin || vi.inner) continue;
    for (int s = 0; s < 2; ++s) {
      const V3 d = out.row(v).transpose() - c.f.eye_center[s];
      const float r = d.norm();
      if (r < c.f.socket_radius && r > 1e-6f)
        out.row(v) = (c.f.eye_center[s] + d * (c.f.socket_radius / r)).transpose();
    }
  }
}

// Rotates the jaw: skin by its jaw weight, lower teeth and tongue rigidly; plus a translation.
void move_jaw(const Ctx& c, rig::Positions& out, float angle, const V3& shift) {
  for (Eigen::Index v = 0; v < out.rows(); ++v) {
    const VertexInfo& vi = c.info(static_cast<int>(v));
    float w = 0;
    if (vi.part == Part::kSkin) w = vi.jaw;
    if (vi.part == Part::kTeethLower || vi.part == Part::kTongue) w = 1;
    if (w <= 0) continue;
    const V3 p = out.row(v).transpose();
    out.row(v) = (rotate_about(p, c.f.jaw_hinge, kX, w * angle) + w * shift).transpose();
  }
}

// ---- eyes ---------------------------------------------------------------------------------

// 1 at the lid margin, falling to 0.35 at the lid's far edge.
float lid_profile(const Frames& f, const VertexInfo& vi) {
  const bool upper = vi.part == Part::kLidUpper;
  const float em = margin_elevation(f, upper, vi.a);
  const float far = upper ? deg(80) : deg(-80);
  const float t = std::clamp((vi.e - em) / (far - em), 0.0f, 1.0f);
  return 1.0f - 0.65f * t;
}

// Rotates one eye's lids (downwards positive) by `upper_angle(a) * profile` and the eyeball by a
// rotation `ball`.
void move_eye(const Ctx& c, rig::Positions& out, int side,
              const std::function<float(float)>& upper_angle,
              const std::function<float(float)>& lower_angle, bool rigid_lids,
              const Eigen::AngleAxisf& ball) {
  const V3 C = c.f.eye_center[side];
  for (Eigen::Index v = 0; v < out.rows(); ++v) {
    const VertexInfo& vi = c.info(static_cast<int>(v));
    if (vi.side != side) continue;
    const V3 p = out.row(v).transpose();
    if (vi.part == Part::kEyeball) {
      out.row(v) = (C + ball * (p - C)).transpose();
    } else if (vi.part == Part::kLidUpper || vi.part == Part::kLidLower) {
      const bool up = vi.part == Part::kLidUpper;
      const float base = up ? upper_angle(vi.a) : lower_angle(vi.a);
      const float angle = base * (rigid_lids ? 1.0f : lid_profile(c.f, vi));
      out.row(v) = rotate_about(p, C, kX, angle).transpose();
    }
  }
}

float blink_lower(const Frames& f, float a) {
  const float q = a / f.corner_angle;
  return -deg(8) * std::max(0.0f, 1.0f - q * q);  // upwards
}
float blink_upper(const Frames& f, float a) {
  const float closed = margin_elevation(f, false, a) - blink_lower(f, a) - deg(3);
  return std::max(0.0f, margin_elevation(f, true, a) - closed);  // downwards
}

// ---- the shapes ---------------------------------------------------------------------------

using ShapeFn = std::function<void(const Ctx&, rig::Positions&)>;

struct ShapeDef {
  std::string name;
  ShapeFn fn;
};

struct ShapeList {
  std::vector<ShapeDef> defs;
  void add(std::string name, ShapeFn fn) { defs.push_back({std::move(name), std::move(fn)}); }
};

constexpr const char* kSides[2] = {"Left", "Right"};

// Eyes: blinks, gaze (the eyeball turns, the lids follow), squint, wide.
void eye_shapes(ShapeList& d) {
  for (int s = 0; s < 2; ++s) {
    const std::string S = kSides[s];
    const float sx = side_sign(s);
    const Eigen::AngleAxisf still(0, kX);
    d.add("eyeBlink" + S, [s, still](const Ctx& c, rig::Positions& o) {
      move_eye(
          c, o, s, [&](float a) { return blink_upper(c.f, a); },
          [&](float a) { return blink_lower(c.f, a); }, false, still);
    });
    d.add("eyeLookDown" + S, [s](const Ctx& c, rig::Positions& o) {
      move_eye(
          c, o, s, [](float) { return deg(12); }, [](float) { return deg(5); }, true,
          Eigen::AngleAxisf(deg(22), kX));
    });
    d.add("eyeLookIn" + S, [s, sx](const Ctx& c, rig::Positions& o) {
      move_eye(
          c, o, s, [](float) { return 0.0f; }, [](float) { return 0.0f; }, true,
          Eigen::AngleAxisf(-sx * deg(25), kY));
    });
    d.add("eyeLookOut" + S, [s, sx](const Ctx& c, rig::Positions& o) {
      move_eye(
          c, o, s, [](float) { return 0.0f; }, [](float) { return 0.0f; }, true,
          Eigen::AngleAxisf(sx * deg(25), kY));
    });
    d.add("eyeLookUp" + S, [s](const Ctx& c, rig::Positions& o) {
      move_eye(
          c, o, s, [](float) { return -deg(12); }, [](float) { return -deg(4); }, true,
          Eigen::AngleAxisf(-deg(20), kX));
    });
    d.add("eyeSquint" + S, [s, still](const Ctx& c, rig::Positions& o) {
      move_eye(
          c, o, s, [](float) { return deg(5); },
          [&](float a) { return 1.1f * blink_lower(c.f, a); }, false, still);
      const V3 under = c.f.eye_center[s] - V3(0, c.f.eye_radius + 0.7f, 0);
      displace_skin(c, o, [s, under](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
        return V3(0, 0.22f, 0.08f) * cc.gauss(vi.anchor, under, 1.2f, 0.8f) * cc.eye_front(vi, s);
      });
      keep_out_of_sockets(c, o);
    });
    d.add("eyeWide" + S, [s, still](const Ctx& c, rig::Positions& o) {
      move_eye(
          c, o, s, [](float) { return -deg(11); }, [](float) { return deg(4); }, false, still);
    });
  }
}

// The jaw: forward, sideways, open (the upper lip lifts a little).
void jaw_shapes(ShapeList& d) {
  d.add("jawForward",
        [](const Ctx& c, rig::Positions& o) { move_jaw(c, o, deg(6), V3(0, 0, 0.5f)); });
  d.add("jawLeft", [](const Ctx& c, rig::Positions& o) { move_jaw(c, o, deg(5), V3(0.6f, 0, 0)); });
  d.add("jawRight",
        [](const Ctx& c, rig::Positions& o) { move_jaw(c, o, deg(5), V3(-0.6f, 0, 0)); });
  d.add("jawOpen", [](const Ctx& c, rig::Positions& o) {
    move_jaw(c, o, kJawOpen, V3::Zero());
    displace_skin(c, o,
                  [](const Ctx& cc, int, const VertexInfo& vi) -> V3 {  // upper lip lifts a little
                    return V3(0, 0.22f, 0.05f) *
                           (cc.upper(vi) * cc.lips(vi) * cc.mouth_area(vi) * (1 - vi.jaw));
                  });
  });
}

// The mouth: fields over the lips and around them.
void mouth_shapes(ShapeList& d) {
  d.add("mouthClose", [](const Ctx& c, rig::Positions& o) {  // undoes jawOpen on the lips
    for (Eigen::Index v = 0; v < o.rows(); ++v) {
      const VertexInfo& vi = c.info(static_cast<int>(v));
      if (vi.part != Part::kSkin || vi.jaw <= 0) continue;
      const V3 p = c.p(static_cast<int>(v));
      const float w = vi.inner ? vi.inner_att : c.mouth_area(vi, 1.0f, 1.6f);
      const V3 opened = rotate_about(p, c.f.jaw_hinge, kX, vi.jaw * kJawOpen);
      o.row(v) += ((p - opened) * w).transpose();
    }
  });
  d.add("mouthFunnel", [](const Ctx& c, rig::Positions& o) {
    displace_skin(c, o, [](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
      const auto q = cc.mp(vi);
      const float mid =
          std::max(0.0f, 1.0f - (q.x() / cc.f.mouth_half_width) * (q.x() / cc.f.mouth_half_width));
      const float open = (0.3f * cc.upper(vi) - 0.36f * cc.lower(vi)) * (0.3f + 0.7f * mid);
      return V3(-0.12f * q.x(), open, 0.45f) * (cc.lips(vi) * cc.mouth_area(vi));
    });
  });
  for (int s = 0; s < 2; ++s) {
    const std::string S = kSides[s];
    const float sx = side_sign(s);
    d.add("mouth" + S, [sx](const Ctx& c, rig::Positions& o) {
      displace_skin(c, o, [sx](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
        return V3(0.7f * sx, 0, 0) * cc.mouth_area(vi, 1.8f, 2.4f);
      });
    });
  }
  d.add("mouthPucker", [](const Ctx& c, rig::Positions& o) {
    displace_skin(c, o, [](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
      const auto q = cc.mp(vi);
      return V3(-0.36f * q.x(), 0, 0.6f + 0.6f * vi.bulge) * (cc.lips(vi) * cc.mouth_area(vi));
    });
  });
  for (int s = 0; s < 2; ++s) {
    const std::string S = kSides[s];
    const float sx = side_sign(s);
    d.add("mouthSmile" + S, [s, sx](const Ctx& c, rig::Positions& o) {
      displace_skin(c, o, [s, sx](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
        const float cheek = cc.gauss(vi.anchor, cc.f.cheek[s], 1.6f, 1.4f) * cc.front(vi);
        return V3(0.6f * sx, 0.85f, -0.18f) * cc.corner(vi, s, 1.35f) + V3(0, 0.3f, 0.15f) * cheek;
      });
      keep_out_of_sockets(c, o);
    });
    d.add("mouthFrown" + S, [s, sx](const Ctx& c, rig::Positions& o) {
      displace_skin(c, o, [s, sx](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
        return V3(0.12f * sx, -0.5f, -0.05f) * cc.corner(vi, s, 1.3f);
      });
    });
    d.add("mouthDimple" + S, [s, sx](const Ctx& c, rig::Positions& o) {
      displace_skin(c, o, [s, sx](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
        return V3(0.22f * sx, 0.05f, -0.22f) * cc.corner(vi, s, 1.2f);
      });
    });
    d.add("mouthStretch" + S, [s, sx](const Ctx& c, rig::Positions& o) {
      displace_skin(c, o, [s, sx](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
        return V3(0.55f * sx, -0.22f, -0.25f) * cc.corner(vi, s, 1.5f);
      });
    });
  }
  d.add("mouthRollLower", [](const Ctx& c, rig::Positions& o) {
    displace_skin(c, o, [](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
      const float b = vi.bulge / std::max(cc.f.lip_bulge_lower, 1e-3f);
      return (-0.7f * vi.bulge * cc.f.lip_dir + V3(0, 0.12f * b, 0)) * cc.lower(vi);
    });
  });
  d.add("mouthRollUpper", [](const Ctx& c, rig::Positions& o) {
    displace_skin(c, o, [](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
      const float b = vi.bulge / std::max(cc.f.lip_bulge_upper, 1e-3f);
      return (-0.7f * vi.bulge * cc.f.lip_dir - V3(0, 0.12f * b, 0)) * cc.upper(vi);
    });
  });
  d.add("mouthShrugLower", [](const Ctx& c, rig::Positions& o) {
    displace_skin(c, o, [](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
      const float y = cc.mp(vi).y();
      return V3(0, 0.3f, 0.15f) * (smoothstep(0.9f, 0.15f, y) * cc.mouth_area(vi, 1.6f, 3.4f));
    });
  });
  d.add("mouthShrugUpper", [](const Ctx& c, rig::Positions& o) {
    displace_skin(c, o, [](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
      return V3(0, 0.3f, 0.12f) * (cc.upper(vi) * cc.mouth_area(vi, 2.0f, 2.2f));
    });
  });
  for (int s = 0; s < 2; ++s) {
    const std::string S = kSides[s];
    const float sx = side_sign(s);
    const auto side_w = [sx](const Ctx& cc, const VertexInfo& vi) {
      const float x = cc.mp(vi).x() - sx * 0.45f * cc.f.mouth_half_width;
      return std::exp(-x * x / (2 * 0.9f * 0.9f));
    };
    d.add("mouthPress" + S, [sx](const Ctx& c, rig::Positions& o) {
      displace_skin(c, o, [sx](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
        const float half = smoothstep(-0.4f, 0.6f, sx * cc.mp(vi).x() / cc.f.mouth_half_width);
        return (-0.45f * vi.bulge * cc.f.lip_dir +
                V3(0.08f * sx, 0, 0) * cc.corner(vi, sx > 0 ? 0 : 1, 0.8f)) *
               half;
      });
    });
    d.add("mouthLowerDown" + S, [side_w](const Ctx& c, rig::Positions& o) {
      displace_skin(c, o, [side_w](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
        return V3(0, -0.42f, 0.05f) *
               (cc.lower(vi) * cc.mouth_area(vi, 1.0f, 2.0f) * side_w(cc, vi));
      });
    });
    d.add("mouthUpperUp" + S, [side_w](const Ctx& c, rig::Positions& o) {
      displace_skin(c, o, [side_w](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
        return V3(0, 0.42f, 0.08f) *
               (cc.upper(vi) * cc.mouth_area(vi, 2.0f, 1.0f) * side_w(cc, vi));
      });
    });
  }
}

// Cheeks and nose.
void cheek_nose_shapes(ShapeList& d) {
  d.add("cheekPuff", [](const Ctx& c, rig::Positions& o) {
    displace_skin(c, o, [](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
      if (vi.inner) return V3(0, 0, 0);
      V3 total(0, 0, 0);
      for (int s = 0; s < 2; ++s) {
        const V3 centre(side_sign(s) * 3.2f * cc.m.params.face_width, cc.f.mouth.y() + 0.9f, 0);
        V3 out = vi.anchor - V3(0, vi.anchor.y(), cc.f.mouth.z() - 5.0f);
        out.y() = 0;
        total += 0.75f * out.normalized() * cc.gauss(vi.anchor, centre, 1.5f, 1.6f);
      }
      return V3(total * smoothstep(0.8f, 1.8f, vi.lip_u) * cc.front(vi));
    });
  });
  for (int s = 0; s < 2; ++s) {
    const std::string S = kSides[s];
    const float sx = side_sign(s);
    d.add("cheekSquint" + S, [s, sx](const Ctx& c, rig::Positions& o) {
      displace_skin(c, o, [s, sx](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
        return V3(0.04f * sx, 0.4f, 0.12f) *
               (cc.gauss(vi.anchor, cc.f.cheek[s], 1.4f, 1.2f) * cc.front(vi));
      });
      keep_out_of_sockets(c, o);
    });
    d.add("noseSneer" + S, [sx](const Ctx& c, rig::Positions& o) {
      displace_skin(c, o, [sx](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
        const V3 centre(sx * 0.95f, cc.f.nose_tip.y() - 0.4f, 0);
        return V3(0.05f * sx, 0.32f, 0.06f) *
               (cc.gauss(vi.anchor, centre, 0.8f, 0.9f) * cc.front(vi));
      });
    });
  }
}

// Brows.
void brow_shapes(ShapeList& d) {
  for (int s = 0; s < 2; ++s) {
    const std::string S = kSides[s];
    const float sx = side_sign(s);
    d.add("browDown" + S, [s, sx](const Ctx& c, rig::Positions& o) {
      displace_skin(c, o, [s, sx](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
        return V3(-0.15f * sx, -0.4f, 0.1f) *
               (cc.gauss(vi.anchor, cc.f.brow[s], 1.6f, 1.0f) * cc.eye_front(vi, s));
      });
      keep_out_of_sockets(c, o);
    });
  }
  d.add("browInnerUp", [](const Ctx& c, rig::Positions& o) {
    displace_skin(c, o, [](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
      float w = 0;
      for (int s = 0; s < 2; ++s) {
        const V3 centre(side_sign(s) * 1.3f, cc.f.brow[s].y() - 0.1f, 0);
        w += cc.gauss(vi.anchor, centre, 1.0f, 1.1f) * cc.eye_front(vi, s);
      }
      return V3(0, 0.8f, 0) * std::min(w, 1.0f);
    });
    keep_out_of_sockets(c, o);
  });
  for (int s = 0; s < 2; ++s) {
    const std::string S = kSides[s];
    const float sx = side_sign(s);
    d.add("browOuterUp" + S, [s, sx](const Ctx& c, rig::Positions& o) {
      displace_skin(c, o, [s, sx](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
        const V3 centre(cc.f.brow[s].x() + sx * 1.3f, cc.f.brow[s].y(), 0);
        return V3(0, 0.7f, 0) * (cc.gauss(vi.anchor, centre, 1.1f, 1.0f) * cc.eye_front(vi, s));
      });
      keep_out_of_sockets(c, o);
    });
  }
}

// The tongue: out between the lips over the lower teeth, with the jaw a little open.
void tongue_shapes(ShapeList& d) {
  d.add("tongueOut", [](const Ctx& c, rig::Positions& o) {
    const auto& line = c.f.tongue_out_line;
    for (Eigen::Index v = 0; v < o.rows(); ++v) {
      const VertexInfo& vi = c.info(static_cast<int>(v));
      if (vi.part != Part::kTongue) continue;
      const float t = vi.along;
      const V3 a = polyline_at(line, std::max(0.0f, t - 0.01f));
      const V3 b = polyline_at(line, std::min(1.0f, t + 0.01f));
      const V3 T = (b - a).normalized();
      const V3 U = T.cross(kX).normalized();
      o.row(v) =
          (polyline_at(line, t) + 0.85f * vi.cross.x() * kX + 0.72f * vi.cross.y() * U).transpose();
    }
    move_jaw(c, o, deg(12), V3::Zero());
    displace_skin(c, o, [](const Ctx& cc, int, const VertexInfo& vi) -> V3 {
      return V3(0, 0.15f, 0.04f) * (cc.upper(vi) * cc.lips(vi) * cc.mouth_area(vi) * (1 - vi.jaw));
    });
  });
}

std::vector<ShapeDef> shape_defs() {
  ShapeList d;
  eye_shapes(d);
  jaw_shapes(d);
  mouth_shapes(d);
  cheek_nose_shapes(d);
  brow_shapes(d);
  tongue_shapes(d);
  return std::move(d.defs);
}

}  // namespace

std::vector<rig::Blendshape> build_shapes(const Model& model) {
  const Ctx c(model);
  std::vector<ShapeDef> defs = shape_defs();
  std::vector<rig::Blendshape> shapes;
  shapes.reserve(defs.size());
  rig::Positions out;
  for (const auto& def : defs) {
    out = model.pos;
    def.fn(c, out);
    shapes.push_back(rig::Blendshape::from_dense(def.name, out - model.pos, 1e-6f));
  }
  return shapes;
}

}  // namespace facecast::avatar::detail
