// The renderer on a textured, skinned avatar made here: a head (a UV sphere whose base-colour
// texture is red on the avatar's left, blue on its right, with a "jawOpen" shape on its lower
// half) on a body (a box), a neck/head skeleton, a masked and a blended card in front.
#include <catch2/catch.hpp>
#include <cmath>

#include "facecast/core/error.hpp"
#include "facecast/render/image.hpp"
#include "facecast/render/renderer.hpp"
#include "gpu_rig.hpp"

using namespace facecast;
using namespace facecast::render;
using rig::Rig;

namespace {

// Appends a part: vertices, UVs, triangles with one material, all joints = `joint`.
void add_part(Rig& rig, const rig::Positions& p, const rig::UVs& uv, const rig::Triangles& t,
              int material, int joint) {
  const auto base = rig.positions.rows();
  const auto add_rows = [](auto& m, const auto& extra) {
    const auto old = m.rows();
    m.conservativeResize(old + extra.rows(), Eigen::NoChange);
    m.bottomRows(extra.rows()) = extra;
  };
  add_rows(rig.positions, p);
  add_rows(rig.uvs, uv);
  rig::Triangles shifted = t.array() + static_cast<int>(base);
  add_rows(rig.triangles, shifted);
  rig.triangle_material.insert(rig.triangle_material.end(), static_cast<std::size_t>(t.rows()),
                               material);
  Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor> j(p.rows(), 4);
  j.setConstant(joint);
  Eigen::Matrix<float, Eigen::Dynamic, 4, Eigen::RowMajor> w(p.rows(), 4);
  w.setZero();
  w.col(0).setOnes();
  add_rows(rig.joints, j);
  add_rows(rig.joint_weights, w);
}

// A UV sphere of radius r about c, u around (from +Z through +X), v from the top.
void add_sphere(Rig& rig, const Eigen::Vector3f& c, float r, int material, int joint) {
  const int nu = 48, nv = 24;
  rig::Positions p((nu + 1) * (nv + 1), 3);
  rig::UVs uv(p.rows(), 2);
  for (int i = 0; i <= nv; ++i)
    for (int k = 0; k <= nu; ++k) {
      const float th = 3.14159265f * static_cast<float>(i) / nv;
      const float ph = 2 * 3.14159265f * static_cast<float>(k) / nu;
      const int v = i * (nu + 1) + k;
      p.row(v) = (c + r * Eigen::Vector3f(std::sin(th) * std::sin(ph), std::cos(th),
                                          std::sin(th) * std::cos(ph)))
                     .transpose();
      uv.row(v) << static_cast<float>(k) / nu, static_cast<float>(i) / nv;
    }
  rig::Triangles t(2 * nu * nv, 3);
  int f = 0;
  for (int i = 0; i < nv; ++i)
    for (int k = 0; k < nu; ++k) {
      const int a = i * (nu + 1) + k, b = a + nu + 1;
      t.row(f++) << a, b, a + 1;
      t.row(f++) << a + 1, b, b + 1;
    }
  add_part(rig, p, uv, t, material, joint);
}

// An axis-aligned quad facing +Z at depth z, from lo to hi in x and y.
void add_quad(Rig& rig, Eigen::Vector2f lo, Eigen::Vector2f hi, float z, int material, int joint) {
  rig::Positions p(4, 3);
  p << lo.x(), lo.y(), z, hi.x(), lo.y(), z, hi.x(), hi.y(), z, lo.x(), hi.y(), z;
  rig::UVs uv(4, 2);
  uv << 0, 1, 1, 1, 1, 0, 0, 0;
  rig::Triangles t(2, 3);
  t << 0, 1, 2, 0, 2, 3;
  add_part(rig, p, uv, t, material, joint);
}

// The box of the body: a closed cuboid (12 triangles).
void add_box(Rig& rig, Eigen::Vector3f lo, Eigen::Vector3f hi, int material, int joint) {
  rig::Positions p(8, 3);
  for (int i = 0; i < 8; ++i)
    p.row(i) << (i & 1 ? hi : lo).x(), (i & 2 ? hi : lo).y(), (i & 4 ? hi : lo).z();
  rig::Triangles t(12, 3);
  t << 0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1,
      3, 5, 3, 7, 5;
  add_part(rig, p, rig::UVs::Zero(8, 2), t, material, joint);
}

// RGBA PNG bytes of w x h pixels from a function of (x, y).
template <class F>
std::string png(int w, int h, F colour) {
  Image img{w, h, 4, {}};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Eigen::Vector4i c = colour(x, y);
      for (int k = 0; k < 4; ++k) img.pixels.push_back(static_cast<std::uint8_t>(c[k]));
    }
  return encode_png(img);
}

enum Materials { kHead, kBody, kMask, kBlend };

Rig textured_avatar() {
  Rig rig;
  rig.positions.resize(0, 3);
  rig.uvs.resize(0, 2);
  rig.triangles.resize(0, 3);
  rig.joints.resize(0, 4);
  rig.joint_weights.resize(0, 4);
  // Joints: 0 spine (root), 1 neck, 2 head.
  rig.skeleton.joint_names = {"Spine", "Neck", "Head"};
  rig.skeleton.parent = {-1, 0, 1};
  rig.skeleton.rest_origin = {{0, 0, 0}, {0, 10, 0}, {0, 12, 0}};
  rig.skeleton.neck = 1;
  rig.skeleton.head = 2;
  // Texture 0: the head, red for u < 0.5 (the avatar's left, +X), blue beyond; texture 1: alpha
  // 0 on the left half, opaque green on the right (the mask card).
  rig.textures.push_back({"head", "image/png", png(64, 32, [](int x, int) {
                            return x < 32 ? Eigen::Vector4i(230, 30, 30, 255)
                                          : Eigen::Vector4i(30, 30, 230, 255);
                          })});
  rig.textures.push_back({"mask", "image/png", png(32, 32, [](int x, int) {
                            return x < 16 ? Eigen::Vector4i(0, 255, 0, 0)
                                          : Eigen::Vector4i(0, 200, 0, 255);
                          })});
  rig::Material head = rig::Material::solid("head", {1, 1, 1, 1});
  head.base_color_texture.texture = 0;
  rig::Material body = rig::Material::solid("body", {0.5f, 0.45f, 0.4f, 1});
  rig::Material mask = rig::Material::solid("mask", {1, 1, 1, 1});
  mask.base_color_texture.texture = 1;
  mask.alpha_mode = rig::AlphaMode::kMask;
  rig::Material blend = rig::Material::solid("veil", {1, 1, 1, 0.5f});
  blend.alpha_mode = rig::AlphaMode::kBlend;
  rig.materials = {head, body, mask, blend};
  add_sphere(rig, {0, 16, 0}, 4, kHead, 2);
  add_box(rig, {-8, -10, -3}, {8, 10, 3}, kBody, 0);
  add_quad(rig, {-9, -8}, {9, -2}, 4, kMask, 0);
  add_quad(rig, {-9, 2}, {-3, 8}, 4, kBlend, 0);
  rig.normals = rig::vertex_normals(rig.positions, rig.triangles);
  // "jawOpen": the sphere's front lower half moves down.
  rig::Positions d = rig::Positions::Zero(rig.positions.rows(), 3);
  for (int v = 0; v < (48 + 1) * (24 + 1); ++v)
    if (rig.positions(v, 1) < 15 && rig.positions(v, 2) > 1) d(v, 1) = -2.5f;
  rig.shapes.push_back(rig::Blendshape::from_dense("jawOpen", d));
  rig.validate("test avatar");
  return rig;
}

RenderOptions options(Framing framing) {
  RenderOptions o;
  o.width = 160;
  o.height = 160;
  o.framing = framing;
  o.contexts = 1;
  return o;
}

Eigen::Vector3i pixel(const Image& img, int x, int y) {
  return {img.at(x, y, 0), img.at(x, y, 1), img.at(x, y, 2)};
}

bool is_background(const Image& img, int x, int y, const RenderOptions& o) {
  return (pixel(img, x, y).cast<float>() - 255.0f * o.background).cwiseAbs().maxCoeff() <= 2;
}

}  // namespace

TEST_CASE("textures, framing and alpha on a textured skinned avatar", "[render][pbr]") {
  const Rig rig = textured_avatar();
  const RenderOptions face = options(Framing::kFace);
  Renderer r(rig, face);
  const std::vector<float> neutral{0.0f};
  const Image img = r.render(neutral);
  // Face framing: the head fills the frame; seen from the front the avatar's left (+X) is on the
  // image's right: red there, blue on the left.
  const Eigen::Vector3i right = pixel(img, 110, 80), left = pixel(img, 50, 80);
  CHECK(right.x() > 2 * right.z());
  CHECK(left.z() > 2 * left.x());
  CHECK_FALSE(is_background(img, 80, 30, face));
  // A texture transform (KHR_texture_transform) half a turn around u swaps the sides.
  Rig turned = rig;
  turned.materials[kHead].base_color_texture.offset.x() = 0.5f;
  const Image swapped = Renderer(turned, face).render(neutral);
  CHECK(pixel(swapped, 110, 80).z() > 2 * pixel(swapped, 110, 80).x());
  CHECK(pixel(swapped, 50, 80).x() > 2 * pixel(swapped, 50, 80).z());

  // Full framing shows the body and the cards: the masked card's transparent half shows the body
  // behind it, its opaque half is green; the blended veil mixes with the body's colour.
  const RenderOptions full = options(Framing::kFull);
  Renderer whole(rig, full);
  const Image all = whole.render(neutral);
  const Camera& cam = whole.camera();
  const auto project = [&](const Eigen::Vector3f& p) {
    const float t = std::tan(0.5f * cam.fov_y_deg * 3.14159265f / 180.0f);
    const Eigen::Vector3f d = p - cam.eye;  // camera looks along -Z, up +Y
    return Eigen::Vector2i(static_cast<int>(80 + 80 * d.x() / (-d.z() * t)),
                           static_cast<int>(80 - 80 * d.y() / (-d.z() * t)));
  };
  const Eigen::Vector2i opaque = project({6, -5, 4}), hole = project({-6, -5, 4}),
                        veil = project({-6, 5, 4}), body = project({6, 5, 3});
  const Eigen::Vector3i green = pixel(all, opaque.x(), opaque.y());
  CHECK(green.y() > green.x() + 60);
  const Eigen::Vector3i through = pixel(all, hole.x(), hole.y());
  const Eigen::Vector3i plain = pixel(all, body.x(), body.y());
  CHECK((through - plain).cwiseAbs().maxCoeff() < 25);  // the body, not the card
  const Eigen::Vector3i veiled = pixel(all, veil.x(), veil.y());
  CHECK(veiled.sum() > plain.sum() + 60);  // half white over the body: lighter
  CHECK(veiled.sum() < 3 * 250);           // but not opaque white
}

TEST_CASE("the head pose turns the head through the neck; the body stays", "[render][pbr]") {
  const Rig rig = textured_avatar();
  const RenderOptions full = options(Framing::kFull);
  Renderer r(rig, full);
  const std::vector<float> neutral{0.0f};
  const Image still = r.render(neutral);
  const Image turned = r.render(neutral, rig::BodyPose{0.6f, 0.0f, 0.0f});
  // Rows of the head change, rows of the body's middle do not.
  const auto row_difference = [&](int y) {
    int d = 0;
    for (int x = 0; x < still.width; ++x)
      for (int c = 0; c < 3; ++c) d += std::abs(still.at(x, y, c) - turned.at(x, y, c));
    return d;
  };
  int head_rows = 0, body_rows = 0;
  for (int y = 0; y < still.height; ++y) {
    const int d = row_difference(y);
    if (y < 40) head_rows += d > 300;
    if (y > 100 && y < 130) body_rows += d > 0;
  }
  CHECK(head_rows > 5);
  CHECK(body_rows == 0);
}

TEST_CASE("jawOpen changes the lower half of the framed face", "[render][pbr]") {
  const Rig rig = textured_avatar();
  Renderer r(rig, options(Framing::kFace));
  const Image closed = r.render(std::vector<float>{0.0f});
  const Image open = r.render(std::vector<float>{1.0f});
  double upper = 0, lower = 0;
  for (int y = 0; y < closed.height; ++y)
    for (int x = 0; x < closed.width; ++x)
      (y < closed.height / 3 ? upper : lower) += std::abs(closed.at(x, y, 1) - open.at(x, y, 1)) +
                                                 std::abs(closed.at(x, y, 2) - open.at(x, y, 2));
  CHECK(lower > 20 * (upper + 1));
}

TEST_CASE("a background image covers the frame; bad textures are one-line errors",
          "[render][pbr]") {
  const Rig rig = textured_avatar();
  RenderOptions o = options(Framing::kFace);
  o.background_image = (std::filesystem::temp_directory_path() / "facecast_bg.png").string();
  Image bg{8, 8, 3, std::vector<std::uint8_t>(8 * 8 * 3, 0)};
  for (std::size_t i = 1; i < bg.pixels.size(); i += 3) bg.pixels[i] = 250;  // green
  write_image(o.background_image, bg);
  const Image img = Renderer(rig, o).render(std::vector<float>{0.0f});
  const Eigen::Vector3i corner = pixel(img, 2, 2);
  CHECK(corner.y() > 240);
  CHECK(corner.x() < 10);

  Rig broken = rig;
  broken.textures[0].bytes = "\x89PNG\r\n\x1a\nnot really";
  CHECK_THROWS_WITH(Renderer(broken, options(Framing::kFace)), Catch::Contains("texture 0 'head'"));
  broken.textures[0].bytes = "GIF89a";
  CHECK_THROWS_WITH(Renderer(broken, options(Framing::kFace)),
                    Catch::Contains("not a PNG, JPEG or WebP"));
  broken = rig;
  broken.materials[0].base_color_texture.texture = 7;
  CHECK_THROWS_WITH(Renderer(broken, options(Framing::kFace)),
                    Catch::Contains("texture out of range"));
}

TEST_CASE("an occlusion map reads the same from its own texture, an ORM texture or another's alpha",
          "[render][pbr]") {
  // The head's occlusion: dark on the upper half of the texture (the top of the head).
  const auto occlusion = [](int w, int h) {
    return png(w, h, [h](int, int y) {
      return y < h / 2 ? Eigen::Vector4i(60, 255, 0, 255) : Eigen::Vector4i(255, 255, 0, 255);
    });
  };
  const auto flat = png(64, 32, [](int, int) { return Eigen::Vector4i(128, 128, 255, 255); });
  const Rig plain = textured_avatar();
  // `orm`: the occlusion image is also the metallic-roughness texture (G 255, B 0: the factors');
  // `width` of the occlusion image (the base colour and the normal map are 64 x 32).
  const auto with_occlusion = [&](bool normal_map, bool orm, int width) {
    Rig rig = plain;
    auto& m = rig.materials[kHead];
    rig.textures.push_back({"occlusion", "image/png", occlusion(width, width / 2)});
    m.occlusion_texture.texture = static_cast<int>(rig.textures.size()) - 1;
    if (orm) m.metallic_roughness_texture.texture = m.occlusion_texture.texture;
    if (normal_map) {
      rig.textures.push_back({"normal", "image/png", flat});
      m.normal_texture.texture = static_cast<int>(rig.textures.size()) - 1;
    }
    return rig;
  };
  struct Case {
    const char* what;
    Rig rig;
    detail::OcclusionSource source;
  };
  const std::vector<Case> cases{
      {"own texture (its size differs)", with_occlusion(true, false, 128), detail::kOwnOcclusion},
      {"the normal map's alpha", with_occlusion(true, false, 64), detail::kOcclusionInNormalAlpha},
      {"the base colour's alpha", with_occlusion(false, false, 64), detail::kOcclusionInBaseAlpha},
      {"an ORM texture's red", with_occlusion(true, true, 64), detail::kOcclusionInRoughnessRed}};
  const RenderOptions o = options(Framing::kFace);
  const std::vector<float> neutral{0.0f};
  const Image none = Renderer(plain, o).render(neutral);
  const Image own = Renderer(cases[0].rig, o).render(neutral);
  const auto mean_difference = [](const Image& a, const Image& b, int rows) {
    double sum = 0;
    for (int y = 0; y < rows; ++y)
      for (int x = 0; x < a.width; ++x)
        for (int c = 0; c < 3; ++c) sum += std::abs(a.at(x, y, c) - b.at(x, y, c));
    return sum / (3.0 * rows * a.width);
  };
  // The occlusion darkens the top of the head (the frame's top 50 rows, background included: 7.5
  // levels on average).
  CHECK(mean_difference(none, own, 50) > 4);
  for (const Case& c : cases) {
    INFO(c.what);
    const detail::PackedRig p = detail::pack_rig(c.rig);
    const detail::PackedMaterial& m = p.materials[kHead];
    CHECK(m.occlusion == c.source);
    CHECK((m.texture[detail::kOcclusionSlot] >= 0) == (c.source == detail::kOwnOcclusion));
    // No texture is uploaded that nothing samples: the folded normal map or base colour replaces
    // its original, the occlusion image is gone.
    std::size_t used = 0;
    for (const auto& pm : p.materials)
      for (int t : pm.texture) used = std::max(used, static_cast<std::size_t>(t + 1));
    CHECK(used == p.textures.size());
    // The same picture wherever the occlusion is read (within the filtering of its edge).
    CHECK(mean_difference(Renderer(c.rig, o).render(neutral), own, o.height) < 1.0);
  }
}

TEST_CASE("MToon draws two flat tones split by the key light, and a rim", "[render][pbr]") {
  Rig rig = textured_avatar();
  rig::Material& head = rig.materials[kHead];
  head.base_color_texture.texture = -1;
  head.base_color = {0.8f, 0.1f, 0.1f, 1.0f};
  const RenderOptions face = options(Framing::kFace);
  const std::vector<float> neutral{0.0f};
  const auto tones = [&](const Rig& r) {
    const Image img = Renderer(r, face).render(neutral);
    // Pixels of the sphere: near the lit colour (sRGB 231, 89, 89), near the shade (sRGB 0, 0,
    // 188, blue), or between.
    int lit = 0, shade = 0, between = 0;
    for (int y = 20; y < 140; ++y)
      for (int x = 20; x < 140; ++x) {
        if (is_background(img, x, y, face)) continue;
        const Eigen::Vector3i p = pixel(img, x, y);
        if ((p - Eigen::Vector3i(231, 89, 89)).cwiseAbs().maxCoeff() <= 6)
          ++lit;
        else if ((p - Eigen::Vector3i(0, 0, 188)).cwiseAbs().maxCoeff() <= 6)
          ++shade;
        else
          ++between;
      }
    return Eigen::Vector3i(lit, shade, between);
  };
  const Eigen::Vector3i pbr = tones(rig);
  rig::Toon toon;
  toon.shade_color = {0.0f, 0.0f, 0.5f};
  toon.shading_toony = 0.95f;
  head.toon = toon;
  const Eigen::Vector3i flat = tones(rig);
  INFO("PBR lit/shade/between " << pbr.transpose() << ", MToon " << flat.transpose());
  const int total = flat.sum();
  CHECK(total > 5000);
  CHECK(flat.x() > total / 5);  // the side the key light (upper left) faces
  CHECK(flat.y() > total / 20);
  CHECK(flat.z() < total / 5);  // a narrow ramp between
  CHECK(pbr.z() > total / 2);   // lit PBR shades smoothly instead
  // A rim brightens the silhouette, not the middle.
  toon.rim_color = {0.0f, 0.6f, 0.0f};
  toon.rim_fresnel_power = 4.0f;
  head.toon = toon;
  const Image rimmed = Renderer(rig, face).render(neutral);
  head.toon->rim_color.setZero();
  const Image plain = Renderer(rig, face).render(neutral);
  CHECK(pixel(rimmed, 80, 80) == pixel(plain, 80, 80));
  int greener = 0, edge = 0;
  for (int x = 0; x < 160; ++x)
    if (!is_background(plain, x, 80, face)) {
      ++edge;
      if (pixel(rimmed, x, 80).y() > pixel(plain, x, 80).y() + 20) ++greener;
    }
  CHECK(greener > 0);
  CHECK(greener < edge / 2);
}
