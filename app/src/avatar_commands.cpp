// facecast avatar default | variant | check
#include <chrono>
#include <iostream>
#include <optional>

#include "facecast/app/commands.hpp"
#include "facecast/avatar/avatar.hpp"
#include "facecast/core/error.hpp"
#include "facecast/rig/intersections.hpp"
#include "facecast/rig/rig_io.hpp"

namespace facecast::cli {
namespace {

struct VariantArgs {
  std::string out;
  std::uint64_t seed = 0;
  std::optional<float> face_width, jaw_length, lip_thickness, eye_size, nose_length;
};

struct AvatarCheckArgs {
  std::uint64_t seed = 0;
};

void write_avatar(const avatar::AvatarParams& p, const std::string& out) {
  const auto t0 = std::chrono::steady_clock::now();
  const rig::Rig rig = avatar::make_avatar(p);
  rig::write_glb(out, rig);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::cerr << "wrote " << out << ": " << rig.vertex_count() << " vertices, "
            << rig.triangle_count() << " triangles, " << rig.shapes.size() << " shapes ("
            << static_cast<int>(ms) << " ms)\n";
}

// Self-intersections of the neutral, each shape at weight 1 and the pairs that animate together.
// Touching lips (the lip-line bands of both lips) are allowed; mouthClose is only meaningful on an
// open jaw and is checked as jawOpen + mouthClose.
int check_avatar(const rig::Rig& rig) {
  const auto ignore = rig::ignore_between_groups(rig, {{"lip_upper", "lip_lower"}});
  rig::IntersectionOptions opt;
  opt.ignore = ignore;
  opt.max_listed = 3;
  int failures = 0;
  const auto run = [&](const std::string& label,
                       const std::vector<std::pair<std::string, float>>& w) {
    rig::Positions p = rig.positions;
    for (const auto& [name, weight] : w) {
      const int s = rig.find_shape(name);
      if (s < 0) throw Error("avatar check: no shape " + name, ErrorCode::kNotFound);
      const auto& sh = rig.shapes[static_cast<std::size_t>(s)];
      for (std::size_t i = 0; i < sh.vertices.size(); ++i)
        p.row(sh.vertices[i]) += weight * sh.deltas.row(static_cast<Eigen::Index>(i));
    }
    const auto r = rig::find_intersections(p, rig.triangles, opt);
    if (r.count) {
      ++failures;
      std::cout << label << ": " << r.count << " intersecting pairs, e.g.";
      for (const auto& [a, b] : r.pairs)
        std::cout << " (" << rig.groups[rig.triangle_group[a]] << " " << a << ", "
                  << rig.groups[rig.triangle_group[b]] << " " << b << ")";
      const auto centre = [&](int t) {
        Eigen::Vector3f c = Eigen::Vector3f::Zero();
        for (int k = 0; k < 3; ++k) c += p.row(rig.triangles(t, k)).transpose() / 3.0f;
        return c;
      };
      const Eigen::Vector3f c = centre(r.pairs.front().first);
      std::cout << " near (" << c.x() << ", " << c.y() << ", " << c.z() << ")\n";
    }
  };
  run("neutral", {});
  for (const auto& s : rig.shapes)
    if (s.name != "mouthClose") run(s.name, {{s.name, 1.0f}});
  for (const auto& pair :
       std::vector<std::pair<std::string, std::string>>{{"jawOpen", "mouthClose"},
                                                        {"jawOpen", "mouthSmileLeft"},
                                                        {"jawOpen", "mouthSmileRight"},
                                                        {"eyeBlinkLeft", "eyeLookDownLeft"},
                                                        {"eyeBlinkRight", "eyeLookDownRight"},
                                                        {"eyeBlinkLeft", "eyeSquintLeft"},
                                                        {"jawOpen", "mouthFunnel"},
                                                        {"jawOpen", "mouthPucker"},
                                                        {"jawOpen", "mouthStretchLeft"}})
    run(pair.first + "+" + pair.second, {{pair.first, 1.0f}, {pair.second, 1.0f}});
  std::cout << (failures ? "FAILED" : "ok") << ": " << failures << " poses with intersections\n";
  return failures;
}

}  // namespace

void add_avatar_commands(CLI::App& app) {
  auto* avatar = app.add_subcommand(
      "avatar", "The built-in procedural avatar (a stylized head with the 52 ARKit blendshapes)");
  avatar->require_subcommand(1);
  add_avatar_photo_command(*avatar);

  auto def_out = std::make_shared<std::string>();
  auto* d = avatar->add_subcommand("default", "Write the default avatar as a GLB");
  d->add_option("--out", *def_out, "Output GLB")->required();
  d->callback([def_out] { write_avatar({}, *def_out); });

  auto var = std::make_shared<VariantArgs>();
  auto* v = avatar->add_subcommand(
      "variant",
      "Write another user with the same topology: proportions drawn from --seed, each "
      "overridable (factors in [0.75, 1.3], 1 = the default avatar)");
  v->add_option("--out", var->out, "Output GLB")->required();
  v->add_option("--seed", var->seed, "Seed for the proportions (0 = the default avatar)")
      ->capture_default_str();
  v->add_option("--face-width", var->face_width, "Face and skull width factor");
  v->add_option("--jaw-length", var->jaw_length, "Lower face height factor");
  v->add_option("--lip-thickness", var->lip_thickness, "Lip bulge factor");
  v->add_option("--eye-size", var->eye_size, "Eyeball size factor");
  v->add_option("--nose-length", var->nose_length, "Nose length factor");
  v->callback([var] {
    avatar::AvatarParams p = avatar::avatar_variant(var->seed);
    if (var->face_width) p.face_width = *var->face_width;
    if (var->jaw_length) p.jaw_length = *var->jaw_length;
    if (var->lip_thickness) p.lip_thickness = *var->lip_thickness;
    if (var->eye_size) p.eye_size = *var->eye_size;
    if (var->nose_length) p.nose_length = *var->nose_length;
    std::cerr << "face_width " << p.face_width << ", jaw_length " << p.jaw_length
              << ", lip_thickness " << p.lip_thickness << ", eye_size " << p.eye_size
              << ", nose_length " << p.nose_length << '\n';
    write_avatar(p, var->out);
  });

  auto chk = std::make_shared<AvatarCheckArgs>();
  auto* c = avatar->add_subcommand(
      "check",
      "Check the generated avatar for self-intersections (neutral, each shape, animated pairs)");
  c->add_option("--seed", chk->seed, "Variant seed (0 = the default avatar)")
      ->capture_default_str();
  c->callback([chk] {
    if (check_avatar(avatar::make_avatar(avatar::avatar_variant(chk->seed))))
      throw Error("avatar check failed", ErrorCode::kInternal);
  });
}

}  // namespace facecast::cli
