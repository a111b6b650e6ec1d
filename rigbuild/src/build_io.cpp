// The rig builder's files: its options (configs/rigbuild/build.json), its report, virtual edges.
#include <cstdio>

#include "facecast/core/config.hpp"
#include "facecast/core/config_reader.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/rigbuild/build.hpp"

namespace facecast::rigbuild {

BuildOptions load_build_options() {
  ConfigReader c = ConfigReader::open(config_path("rigbuild/build.json"));
  BuildOptions o;
  c.read_choice("virtual_edges", o.virtual_edges,
                {{"auto", VirtualEdgeMode::kAuto}, {"off", VirtualEdgeMode::kOff}});
  c.read("lambda", o.lambda)
      .read("gap_scale_limit", o.gap_scale_limit)
      .read("closing_rounds", o.closing_rounds)
      .read("still_tolerance", o.still_tolerance)
      .read("rigid_tolerance", o.rigid_tolerance);
  if (o.lambda < 0) c.fail("lambda", "must not be negative");
  if (o.closing_rounds < 0) c.fail("closing_rounds", "must not be negative");
  c.read_choice("solver", o.solver,
                {{"cholmod", SolverKind::kCholmod}, {"eigen", SolverKind::kEigenLDLT}});
  c.section("eye_look")
      .read("in_out", o.eye_look.in_out)
      .read("up", o.eye_look.up)
      .read("down", o.eye_look.down);
  c.section("contacts")
      .read("enabled", o.contacts.enabled)
      .read("margin", o.contacts.margin)
      .read("part_margin", o.contacts.part_margin)
      .read("weight", o.contacts.weight)
      .read("rounds", o.contacts.rounds);
  c.section("ve")
      .read("d", o.ve.d)
      .read("f", o.ve.f)
      .read("per_vertex", o.ve.per_vertex)
      .read("spacing", o.ve.spacing);
  c.section("registration")
      .read("closest_weights", o.registration.closest_weights)
      .read("iterations_per_step", o.registration.iterations_per_step)
      .read("smoothness", o.registration.smoothness)
      .read("identity", o.registration.identity)
      .read("rest_pull", o.registration.rest_pull)
      .read("max_distance", o.registration.max_distance);
  c.reject_unknown();
  o.landmarks = load_landmark_options();
  return o;
}

namespace {

// What the contacts found and did in one shape.
nlohmann::json crossing_counts(const ShapeQuality& q) {
  return {{"copy_crossings", q.copy_crossings},
          {"copy_crossings_left", q.copy_crossings_left},
          {"part_crossings", q.part_crossings},
          {"part_crossings_left", q.part_crossings_left},
          {"attached_crossings", q.attached_crossings},
          {"attached_crossings_left", q.attached_crossings_left},
          {"crossings", q.crossings},
          {"crossings_left", q.crossings_left},
          {"contacts", q.contacts}};
}

}  // namespace

nlohmann::json build_report_json(const BuildResult& r, const BuildOptions& options) {
  nlohmann::json j;
  const bool edges_on = options.virtual_edges != VirtualEdgeMode::kOff;
  j["vertices"] = r.rig.vertex_count();
  j["virtual_edges"] = {{"mode", options.virtual_edges == VirtualEdgeMode::kAuto   ? "auto"
                                 : options.virtual_edges == VirtualEdgeMode::kFile ? "file"
                                                                                   : "off"},
                        {"count", edges_on ? r.virtual_edges.size() : 0},
                        {"d", r.ve_stats.d},
                        {"spacing", r.ve_stats.spacing},
                        {"candidate_pairs", r.ve_stats.candidate_pairs},
                        {"qualifying_pairs", r.ve_stats.qualifying_pairs},
                        {"lambda", options.lambda},
                        {"gap_scale_limit", options.gap_scale_limit},
                        {"closing_rounds", options.closing_rounds}};
  nlohmann::json contacts = crossing_counts({});  // over every shape
  for (const auto& q : r.quality) {
    const nlohmann::json counts = crossing_counts(q);
    for (const auto& [key, n] : counts.items())
      contacts[key] = contacts[key].get<int>() + n.get<int>();
  }
  contacts["enabled"] = options.contacts.enabled;
  contacts["watched_pairs"] = r.watched_pairs;
  j["contacts"] = contacts;
  j["timings_s"] = {{"landmarks", r.timings.landmarks},
                    {"correspondence", r.timings.correspondence},
                    {"registration", r.timings.registration},
                    {"gradients", r.timings.gradients},
                    {"virtual_edges", r.timings.detect},
                    {"factor", r.timings.factor},
                    {"solve", r.timings.solve},
                    {"contacts", r.timings.contacts},
                    {"total", r.timings.total}};
  if (r.landmarks)
    j["landmarks"] = {{"markers", r.landmarks->markers.size()},
                      {"views", r.landmarks->target.views.size()},
                      {"views_with_face", r.landmarks->target.views_found},
                      {"dropped", r.landmarks->target.dropped}};
  j["factor_nonzeros"] = r.factor_nonzeros;
  j["fixed_vertices"] = r.fixed_vertices;
  j["components"] = nlohmann::json::array();
  for (const auto& c : r.components)
    j["components"].push_back({{"vertices", c.vertices}, {"placement", c.placement}});
  j["shapes"] = nlohmann::json::array();
  for (const auto& q : r.quality) {
    nlohmann::json shape = crossing_counts(q);
    shape["name"] = q.shape;
    shape["max_displacement"] = q.max_displacement;
    shape["gap_change"] = q.gap_change;
    shape["min_gap"] = q.min_gap;
    j["shapes"].push_back(shape);
  }
  return j;
}

void write_virtual_edges_json(const std::filesystem::path& path,
                              const std::vector<VirtualEdge>& edges,
                              const VirtualEdgeStats& stats) {
  nlohmann::json j;
  j["d"] = stats.d;
  j["spacing"] = stats.spacing;
  j["edges"] = nlohmann::json::array();
  for (const auto& e : edges) j["edges"].push_back({e.a, e.b});
  write_file_atomic(path, j.dump() + "\n");
}

std::vector<VirtualEdge> read_virtual_edges_json(const std::filesystem::path& path,
                                                 int vertex_count) {
  const nlohmann::json j = load_json(path);
  if (!j.contains("edges") || !j["edges"].is_array())
    throw Error(path.string() + ": no \"edges\" array");
  std::vector<VirtualEdge> out;
  for (std::size_t i = 0; i < j["edges"].size(); ++i) {
    const auto& e = j["edges"][i];
    if (!e.is_array() || e.size() != 2 || !e[0].is_number_integer() || !e[1].is_number_integer()) {
      throw Error(path.string() + ": edges[" + std::to_string(i) +
                  "] is not a pair of vertex indices");
    }
    const int a = e[0].get<int>(), b = e[1].get<int>();
    if (a < 0 || b < 0 || a >= vertex_count || b >= vertex_count || a == b) {
      throw Error(path.string() + ": edges[" + std::to_string(i) + "] vertex out of range (" +
                  std::to_string(vertex_count) + " vertices)");
    }
    out.push_back({a, b});
  }
  return out;
}

void write_virtual_edges_obj(const std::filesystem::path& path, const rig::Positions& positions,
                             const std::vector<VirtualEdge>& edges) {
  std::string s = "# facecast virtual edges: the target neutral's vertices, one 'l' per edge\n";
  char buf[96];
  for (Eigen::Index v = 0; v < positions.rows(); ++v) {
    std::snprintf(buf, sizeof buf, "v %.7g %.7g %.7g\n", positions(v, 0), positions(v, 1),
                  positions(v, 2));
    s += buf;
  }
  for (const auto& e : edges)
    s += "l " + std::to_string(e.a + 1) + " " + std::to_string(e.b + 1) + "\n";
  write_file_atomic(path, s);
}

}  // namespace facecast::rigbuild
