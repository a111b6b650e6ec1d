// The shipped template (rigbuild/template.hpp, ict_facekit.glb packed by the build) against the ICT
// FaceKit it is made from (../shared/data): ARKit names, visemes, landmarks, parts' materials, and
// its neutral and shapes equal to the source's within the quantization; made again from the source,
// it is the same file byte for byte (the conversion is reproducible).
#include <catch2/catch.hpp>
#include <map>

#include "facecast/core/config.hpp"
#include "facecast/core/files.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/rigbuild/landmarks.hpp"
#include "facecast/rigbuild/photo_avatar.hpp"
#include "facecast/rigbuild/template.hpp"
#include "test_data.hpp"

using namespace facecast;
using namespace facecast::rigbuild;

namespace {

// The FaceKit's vertex -> the shipped file's (its transparent eye layers 24591-25350 dropped).
int shipped_vertex(int v) {
  return v < 24591 ? v : v >= 25351 ? v - 760 : -1;
}

// The source's #V by 3 dense deltas on the shipped file's vertices.
rig::Positions on_shipped(const rig::Positions& source, int shipped_count) {
  rig::Positions out(shipped_count, 3);
  for (Eigen::Index v = 0; v < source.rows(); ++v)
    if (const int w = shipped_vertex(static_cast<int>(v)); w >= 0) out.row(w) = source.row(v);
  return out;
}

}  // namespace

TEST_CASE("the shipped template: ARKit names, visemes, landmarks, the FaceKit's shapes",
          "[rigbuild][template][ict]") {
  const auto dir = test::ict_dir();
  if (!test::require_data(dir / "generic_neutral_mesh.obj")) return;
  const rig::Rig shipped = load_shipped_template();
  const rig::Rig source =
      rig::read_obj_shapes(dir / "generic_neutral_mesh.obj", dir, {"identity*"});
  const int nv = shipped.vertex_count();
  REQUIRE(nv == source.vertex_count() - 760);
  CHECK(std::filesystem::file_size(shipped_template_path()) < 3'000'000);

  // Names: every ARKit name but tongueOut, the FaceKit's extras, the 15 Oculus visemes.
  for (const char* n :
       {"eyeBlinkLeft", "eyeBlinkRight", "jawOpen", "mouthSmileLeft", "mouthFunnel", "browInnerUp",
        "cheekPuff", "noseSneerRight", "mouthRollUpper", "eyeLookInLeft", "cheekRaiser_L",
        "PupilDilate_R", "browInnerUp_L", "cheekPuff_R"})
    CHECK(shipped.find_shape(n) >= 0);
  CHECK(shipped.find_shape("eyeBlink_L") < 0);
  for (const char* v :
       {"sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS", "nn", "RR", "aa", "E", "I", "O", "U"})
    CHECK(shipped.find_shape(std::string("viseme_") + v) >= 0);
  CHECK(shipped.shapes.size() == 51 + 8 + 15);
  const TemplateSummary summary = shipped_template_summary();
  CHECK(summary.vertices == nv);
  CHECK(summary.shapes == shipped.shape_names());

  // Landmarks: the FaceKit's 68 (vertex_indices.json), stored in the file.
  const auto ids = load_json(dir / "vertex_indices.json").at("idx_to_landmark_verts");
  const auto known = known_landmarks(shipped);
  REQUIRE(known);
  REQUIRE(shipped.landmarks.size() == 68);
  for (int k = 0; k < kLandmarkCount; ++k)
    CHECK((*known)[static_cast<std::size_t>(k)] ==
          shipped_vertex(ids[static_cast<std::size_t>(k)]));

  // Parts' materials.
  std::map<std::string, Eigen::Vector4f> colour;
  for (const auto& m : shipped.materials) colour[m.name] = m.base_color;
  for (const char* m :
       {"M_Face", "M_Teeth", "M_GumsTongue", "M_ScleraLeft", "M_IrisRight", "M_EyeLashes"})
    CHECK(colour.contains(m));
  CHECK_FALSE(colour.contains("M_EyeOcclusion"));
  CHECK(colour["M_Teeth"].head<3>().minCoeff() > colour["M_IrisLeft"].head<3>().maxCoeff());

  // The neutral and every shape within the quantization (a rounded coordinate is off by at most
  // half a step: |error| <= step * sqrt(3) per vertex; sums of shapes add the steps).
  const double step = quantization_step(shipped);
  CHECK(step < 2e-3);  // centimetres
  const rig::Positions neutral = on_shipped(source.positions, nv);
  CHECK((shipped.positions - neutral).rowwise().norm().maxCoeff() <= 1.8 * step);
  std::map<std::string, rig::Positions> src;
  for (const auto& s : source.shapes) {
    std::string name = s.name;
    for (const auto& [from, to] : {std::pair{"_L", "Left"}, std::pair{"_R", "Right"}})
      if (name.ends_with(from) && !name.starts_with("PupilDilate") &&
          !name.starts_with("cheekRaiser") && !name.starts_with("browInnerUp") &&
          !name.starts_with("cheekPuff"))
        name = name.substr(0, name.size() - 2) + to;
    src[name] = on_shipped(s.dense(source.vertex_count()), nv);
  }
  REQUIRE(src.size() == 57);
  src["browInnerUp"] = src["browInnerUp_L"] + src["browInnerUp_R"];
  src["cheekPuff"] = src["cheekPuff_L"] + src["cheekPuff_R"];
  const auto table = load_json(config_path("anim/visemes_arkit.json"))["visemes"]["oculus"];
  for (const auto& [viseme, row] : table.items()) {
    rig::Positions d = rig::Positions::Zero(nv, 3);
    for (const auto& [name, w] : row.items())
      if (src.contains(name)) d += w.get<float>() * src[name];
    src["viseme_" + viseme] = d;
  }
  for (const auto& s : shipped.shapes) {
    INFO(s.name);
    REQUIRE(src.contains(s.name));
    const double err = (s.dense(nv) - src[s.name]).rowwise().norm().maxCoeff();
    CHECK(err <= 1.8 * step);
    CHECK(s.max_displacement() > (s.name == "viseme_sil" ? -1.0f : 0.05f));
  }

  // The identity modes: outside the shapes (no channel offers them), each within the quantization
  // of the FaceKit's identityNNN.obj - neutral; the photo avatar reads them from the file.
  for (const auto& name : shipped.shape_names()) CHECK_FALSE(name.starts_with("identity"));
  const std::vector<rig::Positions> modes = read_template_identity(shipped_template_path());
  const std::vector<rig::Positions> truth = ict_identity_modes(dir);
  REQUIRE(modes.size() == 10);
  REQUIRE(truth.size() == 10);
  for (std::size_t k = 0; k < modes.size(); ++k) {
    INFO("identity mode " << k);
    REQUIRE(modes[k].rows() == nv);
    const rig::Positions mode =
        on_shipped(rig::read_obj_positions(dir / ("identity00" + std::to_string(k) + ".obj")) -
                       rig::read_obj_positions(dir / "generic_neutral_mesh.obj"),
                   nv);
    CHECK((truth[k] - mode).cwiseAbs().maxCoeff() == 0.0f);
    CHECK((modes[k] - mode).rowwise().norm().maxCoeff() <= 1.8 * step);
    CHECK(mode.rowwise().norm().maxCoeff() > 0.1f);
  }
  CHECK(load_photo_template(shipped_template_path()).modes.size() == 10);

  // Reproducible: made again from the FaceKit, the same bytes.
  CHECK(compact_glb_bytes(ict_template_rig(dir), truth) == read_file(shipped_template_path()));
}
