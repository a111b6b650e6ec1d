// MPEG-4 FAPs on a rig: the table, the units and basis measured at the feature points, writing a
// performance as FAPs and reading FAPs back into weights.
#include "facecast/anim/fap.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>

#include "facecast/core/config.hpp"
#include "facecast/core/config_reader.hpp"
#include "facecast/core/error.hpp"
#include "fap_detail.hpp"

namespace facecast::anim {
namespace {

using namespace detail;

using Vec3 = Eigen::Vector3d;

// The rig's landmarks as points, with what is known.
struct FeaturePoints {
  std::array<Vec3, kFeaturePoints> p;
  std::array<bool, kFeaturePoints> known{};

  bool any(std::span<const int> ids) const {
    return std::any_of(ids.begin(), ids.end(),
                       [&](int k) { return known[static_cast<std::size_t>(k)]; });
  }
  // The mean of those of `ids` the rig has (a detector may have dropped some).
  Vec3 mean(std::span<const int> ids) const {
    Vec3 sum = Vec3::Zero();
    int n = 0;
    for (int k : ids)
      if (known[static_cast<std::size_t>(k)]) sum += p[static_cast<std::size_t>(k)], ++n;
    return sum / std::max(n, 1);
  }
  // As mean(), for the points that define the units: one of them at least is needed.
  Vec3 need(std::initializer_list<int> ids, const char* what) const {
    const std::span<const int> s(ids.begin(), ids.size());
    if (!any(s))
      throw Error("rig: the FAP units need " + std::string(what) + " (landmark " +
                  std::to_string(*ids.begin()) + (ids.size() > 1 ? "..." : "") +
                  "), which the rig does not have");
    return mean(s);
  }
};

// The face's frame: x towards the subject's left (right eye -> left eye), y up (mouth -> eyes,
// made orthogonal), z = x cross y (forward, out of the face).
struct FaceFrame {
  Eigen::Matrix3d axes;  // columns x, y, z
};

double unit_length(const Fapu& u, FapTable::Feature::Unit unit) {
  using U = FapTable::Feature::Unit;
  switch (unit) {
    case U::kES:
      return u.es0;
    case U::kENS:
      return u.ens0;
    case U::kMNS:
      return u.mns0;
    case U::kMW:
      return u.mw0;
    case U::kIRISD:
      return u.irisd0;
  }
  return u.mns0;
}

}  // namespace

FapTable load_fap_table() {
  const auto path = config_path("anim/fap.json");
  ConfigReader c = ConfigReader::open(path);
  FapTable t;
  nlohmann::json features;
  c.require("features", features);
  if (!features.is_array()) c.fail("features", "expected an array");
  std::bitset<kFapCount> seen;
  for (std::size_t i = 0; i < features.size(); ++i) {
    const std::string where = path.string() + ": features[" + std::to_string(i) + "]";
    ConfigReader f(features[i], where);
    FapTable::Feature e;
    std::string axis;
    f.require("fap", e.fap).require("name", e.name).require("points", e.points);
    f.require("axis", axis).require("sign", e.sign);
    f.read_choice("unit", e.unit,
                  {{"ES", FapTable::Feature::Unit::kES},
                   {"ENS", FapTable::Feature::Unit::kENS},
                   {"MNS", FapTable::Feature::Unit::kMNS},
                   {"MW", FapTable::Feature::Unit::kMW},
                   {"IRISD", FapTable::Feature::Unit::kIRISD}});
    f.reject_unknown();
    if (e.fap < 3 || e.fap > kFapCount || is_head(e.fap) || seen[at(e.fap)])
      f.fail("fap", "expected a FAP 3-68 other than the head's 48-50, listed once");
    seen[at(e.fap)] = true;
    if (e.points.empty() || std::any_of(e.points.begin(), e.points.end(),
                                        [](int k) { return k < 0 || k >= kFeaturePoints; }))
      f.fail("points", "expected landmark indices 0-67");
    if (axis.size() != 1 || axis[0] < 'x' || axis[0] > 'z') f.fail("axis", "expected x, y or z");
    e.axis = axis[0] - 'x';
    if (e.sign != 1 && e.sign != -1) f.fail("sign", "expected 1 or -1");
    t.features.push_back(std::move(e));
  }
  // One name -> number map over the three sets (a name two sets share is the same sound).
  ConfigReader& numbers = c.section("viseme_numbers");
  for (const char* set : {"zh15", "mpeg4", "oculus"}) {
    ConfigReader& table = numbers.section(set);
    for (const auto& name : table.keys()) {
      int number = -1;
      table.require(name, number);
      const auto [it, added] = t.viseme_numbers.emplace(name, number);
      if (number < 0 || number > 14 || it->second != number)
        table.fail(name, "expected an MPEG-4 viseme number 0-14 (the same in every set)");
    }
  }
  std::vector<std::string> expressions;
  c.require("expressions", expressions);
  if (expressions.size() != t.expressions.size())
    c.fail("expressions", "expected the six names of FAP 2's expressions 1-6");
  std::copy(expressions.begin(), expressions.end(), t.expressions.begin());
  c.read("prior_weight", t.prior_weight).read("measured_threshold", t.measured_threshold);
  c.reject_unknown();
  if (!(t.prior_weight > 0)) c.fail("prior_weight", "must be positive");
  if (!(t.measured_threshold >= 0)) c.fail("measured_threshold", "must not be negative");
  return t;
}

FapRig::FapRig(const rig::Rig& rig, std::span<const int, kFeaturePoints> landmarks,
               const FapTable& table)
    : table_(table), shapes_(rig.shape_names()) {
  FeaturePoints fp;
  for (int k = 0; k < kFeaturePoints; ++k) {
    const int v = landmarks[static_cast<std::size_t>(k)];
    if (v < 0 || v >= rig.vertex_count()) continue;
    fp.known[static_cast<std::size_t>(k)] = true;
    fp.p[static_cast<std::size_t>(k)] = rig.positions.row(v).cast<double>().transpose();
  }
  // Eye centres from the corners (the lids' points may be missing or uneven).
  const Vec3 eye_r = fp.need({36, 39}, "the right eye's corners");
  const Vec3 eye_l = fp.need({42, 45}, "the left eye's corners");
  const Vec3 mouth = fp.need({62, 66}, "the mouth's middle");
  const Vec3 nose = fp.need({33}, "the nose's bottom");
  const Vec3 corner_r = fp.need({48}, "the right mouth corner");
  const Vec3 corner_l = fp.need({54}, "the left mouth corner");
  Eigen::Matrix3d axes;
  const Vec3 x = (eye_l - eye_r).normalized();
  const Vec3 up = (eye_l + eye_r) / 2 - mouth;
  const Vec3 y = (up - up.dot(x) * x).normalized();
  axes << x, y, x.cross(y);
  if (!axes.allFinite()) throw Error("rig: its landmarks do not span a face (eyes on the mouth)");
  fapu_.es0 = (eye_l - eye_r).norm();
  fapu_.ens0 = std::abs(((eye_l + eye_r) / 2 - nose).dot(y));
  fapu_.mns0 = std::abs((nose - mouth).dot(y));
  fapu_.mw0 = (corner_l - corner_r).norm();
  // IRISD0 is by definition the opening of the eye at rest (lid to lid); a rig that rests with
  // its eyes shut, or has no lid points, gets a tenth of the eye separation instead.
  double lids = 0;
  int eyes = 0;
  for (const auto& [upper, lower] : {std::pair{std::array{43, 44}, std::array{46, 47}},
                                     std::pair{std::array{37, 38}, std::array{40, 41}}}) {
    if (!fp.any(upper) || !fp.any(lower)) continue;
    lids += (fp.mean(upper) - fp.mean(lower)).norm();
    ++eyes;
  }
  fapu_.irisd0 = std::max(eyes ? lids / eyes : 0.0, 0.1 * fapu_.es0);
  if (!(fapu_.ens0 > 0 && fapu_.mns0 > 0 && fapu_.mw0 > 0))
    throw Error("rig: its landmarks give a zero face animation parameter unit");

  const std::size_t n = shapes_.size();
  basis_.assign(kFapCount * n, 0.0);
  // Each shape's deltas at the landmark vertices (several landmarks may share a vertex).
  std::multimap<int, int> landmarks_at;  // vertex -> landmark
  for (int k = 0; k < kFeaturePoints; ++k)
    if (fp.known[static_cast<std::size_t>(k)])
      landmarks_at.emplace(landmarks[static_cast<std::size_t>(k)], k);
  for (std::size_t s = 0; s < n; ++s) {
    std::array<Vec3, kFeaturePoints> d;
    d.fill(Vec3::Zero());
    const rig::Blendshape& shape = rig.shapes[s];
    for (std::size_t i = 0; i < shape.vertices.size(); ++i) {
      const auto [from, to] = landmarks_at.equal_range(shape.vertices[i]);
      for (auto it = from; it != to; ++it)
        d[static_cast<std::size_t>(it->second)] =
            shape.deltas.row(static_cast<Eigen::Index>(i)).cast<double>().transpose();
    }
    for (const auto& f : table_.features) {
      if (!fp.any(f.points)) continue;
      Vec3 mean = Vec3::Zero();
      int count = 0;
      for (int k : f.points)
        if (fp.known[static_cast<std::size_t>(k)]) mean += d[static_cast<std::size_t>(k)], ++count;
      mean /= count;
      basis_[at(f.fap) * n + s] =
          f.sign * mean.dot(axes.col(f.axis)) / (unit_length(fapu_, f.unit) / 1024.0);
    }
  }
  for (const auto& f : table_.features) {
    double most = 0;
    for (std::size_t s = 0; s < n; ++s) most = std::max(most, std::abs(basis_[at(f.fap) * n + s]));
    measured_[at(f.fap)] = most >= table_.measured_threshold && most > 0;
  }
  for (int h : {kHeadPitch, kHeadYaw, kHeadRoll}) measured_[at(h)] = true;
}

bool FapRig::measured(int fap) const {
  return fap >= 1 && fap <= kFapCount && measured_[at(fap)];
}

double FapRig::basis(int fap, int s) const {
  return basis_[at(fap) * shapes_.size() + static_cast<std::size_t>(s)];
}

void FapRig::encode(std::span<const float> weights, const rig::BodyPose& head,
                    FapFrame& out) const {
  if (weights.size() != shapes_.size())
    throw Error("fap: " + std::to_string(weights.size()) + " weights for " +
                std::to_string(shapes_.size()) + " shapes");
  const std::size_t n = shapes_.size();
  for (int fap = 3; fap <= kFapCount; ++fap) {
    if (!measured_[at(fap)] || is_head(fap)) continue;
    double v = 0;
    for (std::size_t s = 0; s < n; ++s) v += basis_[at(fap) * n + s] * weights[s];
    out.value[at(fap)] = v;
  }
  out.value[at(kHeadPitch)] = head.pitch / kAu;
  out.value[at(kHeadYaw)] = head.yaw / kAu;
  out.value[at(kHeadRoll)] = head.roll / kAu;
  for (int fap = 3; fap <= kFapCount; ++fap) out.mask[at(fap)] = measured_[at(fap)];
}

}  // namespace facecast::anim
