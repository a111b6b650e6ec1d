// The default avatar's UVs and generated textures: the skin (tone, blush, brows) and the irises.
//
// Skin UVs: an azimuthal equidistant map of directions from the skull's centre, centred on the
// back of the head: a direction at angle a from the back lands at radius a / pi of the unit disc,
// at its angle around the mouth axis. The map is continuous everywhere except at the mouth's own
// direction (the rim of the disc), where only the lips and the inner mouth lie, which are not
// textured; so the skin needs no seam. The lids use the same map (they are skin-coloured and lie
// in front of the eye sockets). Eyeball UVs: the same map about each eye's forward axis, the iris's
// rim at 0.52 rad filling most of the disc. See docs/algorithms.md#avatar-textures.
#include <png.h>

#include <cmath>
#include <csetjmp>
#include <cstdint>

#include "facecast/core/error.hpp"
#include "generator.hpp"

namespace facecast::avatar::detail {
namespace {

constexpr int kSkinSize = 512, kIrisSize = 256;
constexpr float kIrisUvAngle = 0.6f;  // polar angle at the rim of the eyeball's UV disc

// 8-bit sRGB RGB pixels to PNG bytes (deterministic). zlib at level 1: the noise in these
// textures barely compresses, and the default level spent 0.4 s of the avatar's 1.3 s on it.
std::string png_bytes(int w, int h, const std::vector<std::uint8_t>& rgb) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    throw Error("avatar texture: libpng could not start", ErrorCode::kInternal);
  }
  std::string out;
  std::vector<png_bytep> rows(static_cast<std::size_t>(h));
  for (int y = 0; y < h; ++y)
    rows[y] = const_cast<png_bytep>(rgb.data() + static_cast<std::size_t>(y) * w * 3);
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw Error("avatar texture: libpng failed to encode", ErrorCode::kInternal);
  }
  png_set_write_fn(
      png, &out,
      [](png_structp p, png_bytep data, png_size_t n) {
        static_cast<std::string*>(png_get_io_ptr(p))->append(reinterpret_cast<char*>(data), n);
      },
      nullptr);
  png_set_compression_level(png, 1);
  png_set_IHDR(png, info, static_cast<png_uint_32>(w), static_cast<png_uint_32>(h), 8,
               PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_set_rows(png, info, rows.data());
  png_write_png(png, info, PNG_TRANSFORM_IDENTITY, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}

// Smooth value noise in [0, 1): a hashed lattice, interpolated with smoothstep.
float lattice(int x, int y, std::uint32_t seed) {
  std::uint32_t h = static_cast<std::uint32_t>(x) * 374761393u +
                    static_cast<std::uint32_t>(y) * 668265263u + seed * 2246822519u;
  h = (h ^ (h >> 13)) * 1274126177u;
  return static_cast<float>((h ^ (h >> 16)) & 0xffffu) / 65536.0f;
}
float noise(float x, float y, std::uint32_t seed) {
  const int ix = static_cast<int>(std::floor(x)), iy = static_cast<int>(std::floor(y));
  const float fx = smoothstep(0, 1, x - ix), fy = smoothstep(0, 1, y - iy);
  const float a = lattice(ix, iy, seed), b = lattice(ix + 1, iy, seed);
  const float c = lattice(ix, iy + 1, seed), d = lattice(ix + 1, iy + 1, seed);
  return (a + (b - a) * fx) + ((c + (d - c) * fx) - (a + (b - a) * fx)) * fy;
}

// The azimuthal equidistant map of directions from `centre`: the direction `middle` at the disc's
// centre, a direction at angle a from it at radius min(a / rim, 1), "up" (+Y) towards the top.
struct DiscMap {
  V3 centre, middle, e1, e2;
  float rim;
  DiscMap(const V3& c, const V3& mid, float rim_angle) : centre(c), middle(mid), rim(rim_angle) {
    e1 = (V3::UnitX() - V3::UnitX().dot(middle) * middle).normalized();
    e2 = e1.cross(middle);
  }
  Eigen::Vector2f uv(const V3& p) const {
    const V3 d = (p - centre).normalized();
    const float r = std::min(std::acos(std::clamp(d.dot(middle), -1.0f, 1.0f)) / rim, 1.0f);
    const float t = std::atan2(d.dot(e2), d.dot(e1));
    return {0.5f + 0.5f * r * std::cos(t), 0.5f - 0.5f * r * std::sin(t)};
  }
  V3 direction(float u, float v) const {
    const float x = 2 * u - 1, y = 1 - 2 * v;
    const float a = std::min(std::hypot(x, y), 1.0f) * rim, t = std::atan2(y, x);
    return std::cos(a) * middle + std::sin(a) * (std::cos(t) * e1 + std::sin(t) * e2);
  }
};

}  // namespace

void Generator::paint_textures(Model& m) const {
  const V3 centre = head.cran_c;
  const DiscMap skin(centre, -(f.mouth - centre).normalized(), kPi);  // the back in the middle
  m.uvs = rig::UVs::Zero(m.pos.rows(), 2);
  for (Eigen::Index v = 0; v < m.pos.rows(); ++v) {
    const VertexInfo& vi = m.info[static_cast<std::size_t>(v)];
    const V3 p = m.pos.row(v).transpose();
    if (vi.part == Part::kSkin || vi.part == Part::kLidUpper || vi.part == Part::kLidLower) {
      m.uvs.row(v) = skin.uv(p).transpose();
    } else if (vi.part == Part::kEyeball) {
      const DiscMap eye(f.eye_center[vi.side], V3::UnitZ(),
                        kIrisUvAngle);  // the eyes look along +Z
      m.uvs.row(v) = eye.uv(p).transpose();
    }
  }

  // Skin: the surface point of each texel on a coarse grid of rays from the skull's centre
  // (interpolated between rays), where the brows and the cheeks' blush are painted.
  constexpr int kRays = 65;
  std::vector<V3> surface(kRays * kRays);
  for (int j = 0; j < kRays; ++j)
    for (int i = 0; i < kRays; ++i)
      surface[j * kRays + i] = head.raycast(
          centre,
          skin.direction(static_cast<float>(i) / (kRays - 1), static_cast<float>(j) / (kRays - 1)));
  std::vector<std::uint8_t> rgb(static_cast<std::size_t>(kSkinSize) * kSkinSize * 3);
  const V3 tone(236, 188, 158), blush(222, 150, 138), brow(92, 62, 44);
  for (int y = 0; y < kSkinSize; ++y)
    for (int x = 0; x < kSkinSize; ++x) {
      const float gx = (x + 0.5f) / kSkinSize * (kRays - 1),
                  gy = (y + 0.5f) / kSkinSize * (kRays - 1);
      const int i = std::min(static_cast<int>(gx), kRays - 2),
                j = std::min(static_cast<int>(gy), kRays - 2);
      const float fx = gx - i, fy = gy - j;
      const V3 p =
          (1 - fy) * ((1 - fx) * surface[j * kRays + i] + fx * surface[j * kRays + i + 1]) +
          fy * ((1 - fx) * surface[(j + 1) * kRays + i] + fx * surface[(j + 1) * kRays + i + 1]);
      V3 c = tone * (0.97f + 0.05f * noise(p.x() * 0.8f, p.y() * 0.8f + p.z() * 0.5f, 1) +
                     0.02f * noise(x * 0.7f, y * 0.7f, 2));
      for (int s = 0; s < 2; ++s) {
        const float cheek = std::exp(-(p - f.cheek[s]).squaredNorm() / 4.0f);
        c += 0.35f * cheek * (blush - c);
        // Hairs along the brow: streaks across it, stronger in its middle.
        const float w =
            brow_weight(p, s) * (0.7f + 0.3f * noise(p.x() * 9.0f, p.y() * 2.0f, 3 + s));
        c += std::clamp(w, 0.0f, 1.0f) * 0.9f * (brow - c);
      }
      for (int k = 0; k < 3; ++k)
        rgb[(static_cast<std::size_t>(y) * kSkinSize + x) * 3 + k] =
            static_cast<std::uint8_t>(std::clamp(std::lround(c[k]), 0L, 255L));
    }
  m.textures.push_back({"T_Skin", "image/png", png_bytes(kSkinSize, kSkinSize, rgb)});

  // Iris: a radial pattern of fibres between the pupil (0.21 rad) and the limbal ring (0.52).
  rgb.assign(static_cast<std::size_t>(kIrisSize) * kIrisSize * 3, 0);
  const V3 inner(120, 150, 120), outer(58, 112, 138), ring(30, 44, 56);
  for (int y = 0; y < kIrisSize; ++y)
    for (int x = 0; x < kIrisSize; ++x) {
      const float dx = 2 * (x + 0.5f) / kIrisSize - 1, dy = 2 * (y + 0.5f) / kIrisSize - 1;
      const float th = std::hypot(dx, dy) * kIrisUvAngle, around = std::atan2(dy, dx);
      const float t = std::clamp((th - 0.21f) / (0.52f - 0.21f), 0.0f, 1.0f);
      V3 c = inner + smoothstep(0.0f, 0.6f, t) * (outer - inner);
      c *= 0.8f + 0.35f * noise(around * 40.0f / kPi, t * 3.0f, 7);
      c += smoothstep(0.8f, 1.0f, t) * (ring - c);
      for (int k = 0; k < 3; ++k)
        rgb[(static_cast<std::size_t>(y) * kIrisSize + x) * 3 + k] =
            static_cast<std::uint8_t>(std::clamp(std::lround(c[k]), 0L, 255L));
    }
  m.textures.push_back({"T_Iris", "image/png", png_bytes(kIrisSize, kIrisSize, rgb)});

  for (rig::Material& mat : m.materials) {
    if (mat.name == "M_Skin") {
      mat.base_color = Eigen::Vector4f::Ones();
      mat.base_color_texture.texture = 0;
    } else if (mat.name == "M_Iris") {
      mat.base_color = Eigen::Vector4f::Ones();
      mat.base_color_texture.texture = 1;
    }
  }
}

}  // namespace facecast::avatar::detail
