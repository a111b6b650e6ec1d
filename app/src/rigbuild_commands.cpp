// facecast rig build | check
#include <charconv>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>

#include "facecast/app/commands.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/render/image.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/rigbuild/build.hpp"
#include "facecast/rigbuild/build_target.hpp"
#include "facecast/rigbuild/correspondence.hpp"
#include "facecast/rigbuild/landmarks.hpp"
#include "facecast/rigbuild/picture.hpp"
#include "facecast/rigbuild/quality.hpp"
#include "facecast/rigbuild/template.hpp"
#include "progress.hpp"

namespace facecast::cli {
namespace {

struct BuildArgs {
  std::string tmpl, tmpl_neutral, tmpl_shapes, target, markers, out, obj_out, report, fixed;
  std::string correspondence, ve_mode = "auto", ve_pair, ve_out, ve_png, crossings_png,
                              solver = "cholmod";
  std::string contacts = "on";
  std::string markers_out, landmarks_png;  // what the automatic landmarks found
  rigbuild::BuildOptions opt;
};

std::vector<int> read_fixed(const std::filesystem::path& path) {
  // JSON array of vertex indices, or whitespace-separated indices.
  const std::string text = read_file(path);
  std::vector<int> out;
  if (!text.empty() && text.find('[') != std::string::npos) {
    const auto j = load_json(path);
    for (const auto& v : j) {
      if (!v.is_number_integer())
        throw Error(path.string() + ": expected an array of vertex indices");
      out.push_back(v.get<int>());
    }
    return out;
  }
  const char* p = text.data();
  const char* end = p + text.size();
  int line = 1;
  while (p < end) {
    if (*p == '\n') ++line;
    if (std::isspace(static_cast<unsigned char>(*p)) || *p == ',') {
      ++p;
      continue;
    }
    int v = 0;
    auto [q, ec] = std::from_chars(p, end, v);
    if (ec != std::errc())
      throw Error(path.string() + ":" + std::to_string(line) + ": bad vertex index");
    out.push_back(v);
    p = q;
  }
  return out;
}

// Lip bands of the built-in avatar may touch; other rigs have no such groups.
const rigbuild::IntersectionCheck kCheck = {{{"lip_upper", "lip_lower"}}, {}};

nlohmann::json intersections_json(const rigbuild::IntersectionSummary& s) {
  nlohmann::json j = {{"neutral", s.neutral},
                      {"reference_neutral", s.reference_neutral},
                      {"seconds", s.seconds},
                      {"shapes_with_new_pairs", 0}};
  std::map<std::string, std::size_t> by_parts;  // over every shape
  for (const auto& r : s.shapes) {
    j["shapes_with_new_pairs"] = j["shapes_with_new_pairs"].get<int>() + (r.fresh > 0);
    for (const auto& [parts, n] : r.fresh_by_parts) by_parts[parts] += n;
    nlohmann::json pairs = nlohmann::json::array();
    for (const auto& [x, y] : r.fresh_pairs) pairs.push_back({x, y});
    j["per_shape"][r.shape] = {
        {"total", r.total}, {"in_neutral", r.in_neutral},       {"in_reference", r.in_reference},
        {"new", r.fresh},   {"new_by_parts", r.fresh_by_parts}, {"new_pairs", pairs}};
  }
  j["new_by_parts"] = by_parts;
  return j;
}

nlohmann::json report_json(const rigbuild::BuildResult& r, const BuildArgs& a,
                           const rigbuild::IntersectionSummary& inter) {
  nlohmann::json j = rigbuild::build_report_json(r, a.opt);
  j["target"] = a.target;
  j["intersections"] = intersections_json(inter);
  for (std::size_t k = 0; k < j["shapes"].size() && k < inter.shapes.size(); ++k)
    j["shapes"][k]["intersections"] = j["intersections"]["per_shape"][inter.shapes[k].shape];
  j["intersections"].erase("per_shape");
  j["timings_s"]["intersections"] = inter.seconds;
  return j;
}

// The options' data from the files the flags name (markers, virtual edges, fixed vertices) and
// the correspondence cache: a saved correspondence is reused, else the one computed is saved.
std::filesystem::path read_build_files(BuildArgs& a, const rig::Rig& tmpl, const rig::Rig& target) {
  auto& opt = a.opt;
  if (a.ve_mode != "auto" && a.ve_mode != "off") {
    opt.virtual_edges = rigbuild::VirtualEdgeMode::kFile;
    opt.given_edges = rigbuild::read_virtual_edges_json(a.ve_mode, target.vertex_count());
  }
  if (!a.fixed.empty()) opt.fixed = read_fixed(a.fixed);
  if (a.markers.empty()) return {};
  opt.markers = rigbuild::read_markers(a.markers, tmpl.vertex_count(), target.vertex_count());
  const std::filesystem::path cache =
      a.correspondence.empty() ? std::filesystem::path(a.out).replace_extension(".correspondence")
                               : std::filesystem::path(a.correspondence);
  if (std::filesystem::exists(cache)) {
    opt.correspondence =
        rigbuild::load_correspondence(cache, tmpl.vertex_count(), tmpl.triangle_count(),
                                      target.vertex_count(), target.triangle_count());
  }
  return cache;
}

void run_build(BuildArgs& a) {
  if (!a.tmpl.empty() && !(a.tmpl_neutral.empty() && a.tmpl_shapes.empty()))
    throw Error("give --template rig.glb, or --template-neutral N.obj with --template-shapes DIR");
  if (a.tmpl_neutral.empty() != a.tmpl_shapes.empty())
    throw Error("--template-neutral and --template-shapes go together");
  auto& opt = a.opt;
  opt.solver =
      a.solver == "eigen" ? rigbuild::SolverKind::kEigenLDLT : rigbuild::SolverKind::kCholmod;
  opt.virtual_edges =
      a.ve_mode == "off" ? rigbuild::VirtualEdgeMode::kOff : rigbuild::VirtualEdgeMode::kAuto;
  opt.contacts.enabled = a.contacts == "on";

  std::cerr << "reading template and target...\n";
  // Neither given: the shipped ICT FaceKit template (rigbuild/template.hpp).
  const rig::Rig tmpl = !a.tmpl.empty() ? rig::load_rig(a.tmpl)
                        : !a.tmpl_neutral.empty()
                            ? rig::read_obj_shapes(a.tmpl_neutral, a.tmpl_shapes, {"identity*"})
                            : rigbuild::load_shipped_template();
  const rigbuild::BuildTarget user = rigbuild::BuildTarget::read(a.target);
  const rig::Rig& target = user.neutral();
  const std::filesystem::path cache = read_build_files(a, tmpl, target);
  if (!a.ve_pair.empty()) {
    int i = -1, j = -1;
    if (std::sscanf(a.ve_pair.c_str(), "%d,%d", &i, &j) != 2)
      throw Error("--ve-pair: expected I,J");
    opt.ve.d = rigbuild::ve_distance_from_pair(rig::to_points(target.positions), i, j);
  }
  const auto r = rigbuild::build_rig(tmpl, target, opt, terminal_progress());
  if (!cache.empty() && !opt.correspondence) rigbuild::save_correspondence(cache, r.correspondence);

  // An avatar target keeps its file: the new shapes go into its own meshes.
  write_file_atomic(a.out, user.glb_bytes(r.rig));
  if (r.landmarks) {
    std::fprintf(stderr, "landmarks: %zu marker pairs from %d of %zu views (%.2f s)\n",
                 r.landmarks->markers.size(), r.landmarks->target.views_found,
                 r.landmarks->target.views.size(), r.timings.landmarks);
    if (!a.markers_out.empty()) rigbuild::write_markers_json(a.markers_out, r.landmarks->markers);
    if (!a.landmarks_png.empty())
      render::write_image(a.landmarks_png, rigbuild::landmark_picture(r.landmarks->target));
  } else if (!a.markers_out.empty() || !a.landmarks_png.empty()) {
    std::fprintf(stderr, "no landmarks were detected (markers given, or the same topology)\n");
  }
  if (!a.obj_out.empty()) rig::write_obj_folder(a.obj_out, r.rig);
  if (!a.ve_out.empty()) {
    const std::filesystem::path obj(a.ve_out);
    rigbuild::write_virtual_edges_obj(obj, r.rig.positions, r.virtual_edges);
    rigbuild::write_virtual_edges_json(std::filesystem::path(obj).replace_extension(".json"),
                                       r.virtual_edges, r.ve_stats);
  }
  if (!a.ve_png.empty())
    rigbuild::write_virtual_edge_picture(a.ve_png, r.rig, r.rig.positions, r.virtual_edges);
  if (!a.report.empty() || !a.crossings_png.empty()) {
    std::cerr << "checking self-intersections of every shape...\n";
    const auto inter = rigbuild::shape_intersections(r.rig, &tmpl, r.correspondence.map, kCheck);
    const auto with_new = static_cast<int>(std::count_if(inter.shapes.begin(), inter.shapes.end(),
                                                         [](auto& x) { return x.fresh > 0; }));
    if (!a.report.empty()) {
      write_file_atomic(a.report, report_json(r, a, inter).dump(2) + "\n");
      std::fprintf(stderr,
                   "report %s: %d of %zu shapes have new intersecting triangle pairs (%.2f s)\n",
                   a.report.c_str(), with_new, inter.shapes.size(), inter.seconds);
    }
    if (!a.crossings_png.empty()) {
      const auto progress = terminal_progress();
      int written = 0;
      for (std::size_t k = 0; k < inter.shapes.size(); ++k) {
        const auto& x = inter.shapes[k];
        if (!x.fresh) continue;
        const rig::Positions posed = r.rig.positions + r.rig.shapes[k].dense(r.rig.vertex_count());
        rigbuild::write_crossing_picture(
            std::filesystem::path(a.crossings_png) / (x.shape + ".png"), r.rig, posed,
            x.fresh_pairs);
        progress("pictures of new crossings", static_cast<double>(++written) / with_new);
      }
      std::fprintf(stderr, "wrote %d pictures of new crossings to %s\n", written,
                   a.crossings_png.c_str());
    }
  }
  std::fprintf(
      stderr,
      "wrote %s: %d vertices, %zu shapes, %zu virtual edges (%s); %.2f s (correspondence %.2f: "
      "landmarks %.2f, registration %.2f; virtual edges %.2f, factor %.2f, solve %.2f, contacts "
      "%.2f)\n",
      a.out.c_str(), r.rig.vertex_count(), r.rig.shapes.size(), r.virtual_edges.size(),
      a.ve_mode.c_str(), r.timings.total, r.timings.correspondence, r.timings.landmarks,
      r.timings.registration, r.timings.detect, r.timings.factor, r.timings.solve,
      r.timings.contacts);
}

struct RigCheckArgs {
  std::string rig, truth, reference;
};

void run_check(const RigCheckArgs& a) {
  const rig::Rig rig = rig::load_rig(a.rig);
  nlohmann::json j;
  j["rig"] = a.rig;
  std::vector<rig::Positions> truth;
  if (!a.truth.empty()) {
    for (const auto& s : rig.shapes)
      truth.push_back(rig::read_obj_positions(std::filesystem::path(a.truth) / (s.name + ".obj")));
  }
  const auto errors =
      truth.empty() ? std::vector<rigbuild::ShapeError>{} : rigbuild::truth_errors(rig, truth);
  // Self-intersections per shape, split against a same-topology reference (the template).
  std::optional<rig::Rig> reference;
  auto map = rigbuild::TriangleMap::identity(rig.triangle_count());
  if (!a.reference.empty()) {
    reference = rig::load_rig(a.reference);
    const auto same = rigbuild::same_topology_correspondence(
        reference->vertex_count(), rig::Triangles(reference->triangles), rig.vertex_count(),
        rig::Triangles(rig.triangles));
    if (!same)
      throw Error(a.reference + ": --template must have the rig's topology (" +
                  std::to_string(rig.vertex_count()) + " vertices, " +
                  std::to_string(rig.triangle_count()) + " triangles)");
    map = same->map;
  }
  const auto inter =
      rigbuild::shape_intersections(rig, reference ? &*reference : nullptr, map, kCheck);
  j["intersections"] = intersections_json(inter);
  for (std::size_t k = 0; k < rig.shapes.size(); ++k) {
    nlohmann::json s = {{"name", rig.shapes[k].name},
                        {"max_displacement", rig.shapes[k].max_displacement()}};
    if (k < errors.size()) {
      s["error"] = {{"mean", errors[k].mean},
                    {"p99", errors[k].p99},
                    {"max", errors[k].max},
                    {"p99_percent_of_diagonal", errors[k].p99_percent}};
    }
    j["shapes"].push_back(s);
  }
  std::cout << j.dump(2) << '\n';
}

}  // namespace

void add_rig_build_commands(CLI::App& rig) {
  auto a = std::make_shared<BuildArgs>();
  auto* b = rig.add_subcommand(
      "build", "Generate a user's blendshapes from a template rig by deformation transfer");
  b->add_option("--template", a->tmpl,
                "Template rig (GLB; default: the shipped ICT FaceKit, ict_facekit.glb)")
      ->check(CLI::ExistingFile);
  b->add_option("--template-neutral", a->tmpl_neutral, "Template neutral OBJ")
      ->check(CLI::ExistingFile);
  b->add_option("--template-shapes", a->tmpl_shapes, "Folder of template shape OBJs")
      ->check(CLI::ExistingDirectory);
  b->add_option("--target", a->target,
                "The user's neutral head (OBJ), or avatar (GLB, .gltf, VRM: the output is that "
                "file with the new shapes in its face meshes)")
      ->required()
      ->check(CLI::ExistingFile);
  b->add_option("--markers", a->markers,
                "Marker pairs JSON for another topology (default: found by automatic landmarks)")
      ->check(CLI::ExistingFile);
  b->add_option("--markers-out", a->markers_out,
                "Write the marker pairs the automatic landmarks found (the --markers format)");
  b->add_option("--landmarks-png", a->landmarks_png,
                "Write the landmark views with the points dlib found (green: used)");
  b->add_option("--correspondence", a->correspondence,
                "Correspondence cache (default: next to --out)");
  b->add_option("--out", a->out, "Output rig (GLB)")->required();
  b->add_option("--obj-out", a->obj_out, "Also write neutral.obj and one OBJ per shape here");
  b->add_option("--report", a->report, "Quality report (JSON)");
  b->add_option("--fixed", a->fixed,
                "Vertices that never move (JSON array or whitespace-separated)")
      ->check(CLI::ExistingFile);
  b->add_option("--virtual-edges", a->ve_mode, "auto | off | FILE (JSON from --ve-out)")
      ->capture_default_str();
  b->add_option("--lambda", a->opt.lambda, "Weight of the virtual-edge term")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  b->add_option("--ve-d", a->opt.ve.d, "Euclidean threshold d (0 = estimate from the mesh)")
      ->capture_default_str();
  b->add_option("--ve-f", a->opt.ve.f, "Geodesic / Euclidean ratio threshold f (>= 2)")
      ->capture_default_str();
  b->add_option("--ve-per-vertex", a->opt.ve.per_vertex, "Edges kept per source vertex")
      ->capture_default_str();
  b->add_option("--ve-spacing", a->opt.ve.spacing,
                "Density-control radius (0 = half the median edge length)")
      ->capture_default_str();
  b->add_option("--ve-pair", a->ve_pair,
                "I,J: take d from this target vertex pair across a region");
  b->add_option("--ve-out", a->ve_out,
                "Write the virtual edges as OBJ lines (and .json beside it)");
  b->add_option("--ve-png", a->ve_png, "Write a picture of the virtual edges over the mesh");
  b->add_option("--crossings-png", a->crossings_png,
                "Write DIR/<shape>.png for every shape with new intersecting triangle pairs, "
                "those triangles in red");
  b->add_option("--contacts", a->contacts,
                "on | off: hold apart surfaces that a shape pushes "
                "through each other where the template's does not")
      ->capture_default_str()
      ->check(CLI::IsMember({"on", "off"}));
  b->add_option("--contact-margin", a->opt.contacts.margin,
                "Watch triangle pairs within this distance (0 = half the median edge)")
      ->capture_default_str();
  b->add_option("--contact-part-margin", a->opt.contacts.part_margin,
                "Watch skin near rigidly moved parts (teeth, eyes) within this distance "
                "(0 = two median edges)")
      ->capture_default_str();
  b->add_option("--solver", a->solver, "cholmod | eigen")
      ->capture_default_str()
      ->check(CLI::IsMember({"cholmod", "eigen"}));
  // Defaults come from configs/rigbuild/build.json (the struct mirrors it); flags override.
  b->preparse_callback([a](std::size_t) {
    a->opt = rigbuild::load_build_options();
    a->ve_mode = a->opt.virtual_edges == rigbuild::VirtualEdgeMode::kOff ? "off" : "auto";
    a->solver = a->opt.solver == rigbuild::SolverKind::kEigenLDLT ? "eigen" : "cholmod";
    a->contacts = a->opt.contacts.enabled ? "on" : "off";
  });
  b->callback([a] { run_build(*a); });

  auto c = std::make_shared<RigCheckArgs>();
  auto* ck = rig.add_subcommand(
      "check", "Report per-shape measures of a rig, and errors against ground truth");
  ck->add_option("rig", c->rig, "Rig (GLB)")->required()->check(CLI::ExistingFile);
  ck->add_option("--truth", c->truth, "Folder of ground-truth OBJs named like the shapes")
      ->check(CLI::ExistingDirectory);
  ck->add_option("--template", c->reference,
                 "Same-topology template: split intersecting pairs into in-template and new")
      ->check(CLI::ExistingFile);
  ck->callback([c] { run_check(*c); });

  auto pack = std::make_shared<std::pair<std::string, std::string>>();
  auto* pt = rig.add_subcommand(
      "pack-template",
      "Make the shipped template (ict_facekit.glb, the build runs it) from the ICT FaceKit");
  pt->add_option("--ict", pack->first, "The FaceKit's FaceXModel folder")
      ->required()
      ->check(CLI::ExistingDirectory);
  pt->add_option("--out", pack->second, "Output GLB")->required();
  pt->callback([pack] {
    const rig::Rig ict = rigbuild::ict_template_rig(pack->first);
    const auto identity = rigbuild::ict_identity_modes(pack->first);
    const std::string bytes = rigbuild::compact_glb_bytes(ict, identity);
    write_file_atomic(pack->second, bytes);
    std::fprintf(stderr, "wrote %s: %d vertices, %zu shapes, %zu identity modes, %zu bytes\n",
                 pack->second.c_str(), ict.vertex_count(), ict.shapes.size(), identity.size(),
                 bytes.size());
  });
}

}  // namespace facecast::cli
