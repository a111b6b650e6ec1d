#pragma once
// MPEG-4 facial animation parameters (ISO/IEC 14496-2 FBA), the four-layer control of the MPEG-4
// seed paper: high-level FAPs (1: visemes, 2: expressions) -> low-level FAPs 3-68 (displacements of
// feature points in face animation parameter units) -> feature points -> mesh.
//
// Files are the FBA ASCII form that MPEG-4 players (Xface, Greta) read and write:
//   <version> <name> <fps> <frames>        header ("2.1 facecast 25 250"); '#' lines are comments
//   then per frame two lines:
//   <68 mask bits, 0 or 1>                  which FAPs the frame sets (FAP n is the n-th bit)
//   <frame> <values of the set FAPs>       FAP 1 takes four values (viseme_select1,
//                                          viseme_select2, viseme_blend 0-63, viseme_def), FAP 2
//                                          six (expression_select1, expression_intensity1,
//                                          expression_select2, expression_intensity2, init_face,
//                                          expression_def), FAPs 3-68 one each.
// A FAP a frame does not set keeps its previous value (0 until first set); frame numbers count up
// from 0 and a frame that is not listed repeats the one before it.
//
// A rig speaks FAPs through its feature points: the 68 landmarks (iBUG order) that the rig builder
// knows or detects. FapRig measures the face animation parameter units on the neutral face (ES0,
// ENS0, MNS0, MW0, IRISD0; a unit is 1/1024 of each, AU is 1e-5 rad) and, through the table
// configs/anim/fap.json (each FAP's feature point, axis and direction), what every blendshape
// does to every FAP: a linear map B (FAPs x shapes). Writing is f = B w; reading solves the
// bounded least squares min |B w - f|^2 + lambda |w - w_high|^2, 0 <= w <= 1, where w_high is what
// FAP 1 and 2 ask for through the rig's viseme and expression tables -- the low level refines the
// high level, as in the standard. docs/algorithms.md#mpeg-4-facial-animation-parameters.
#include <array>
#include <bitset>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "facecast/anim/animation.hpp"
#include "facecast/rig/motion.hpp"
#include "facecast/rig/rig.hpp"

namespace facecast::anim {

inline constexpr int kFapCount = 68;
inline constexpr int kFeaturePoints = 68;  // the iBUG 68 landmarks

/// FAP 1: two of the 15 MPEG-4 visemes (0 none, 1 p b m, 2 f v, 3 T D, 4 t d, 5 k g, 6 tS dZ S,
/// 7 s z, 8 n l, 9 r, 10 A:, 11 e, 12 I, 13 Q, 14 U) and how much of the first (blend/63).
struct FapViseme {
  int select1 = 0, select2 = 0, blend = 63, def = 0;
};

/// FAP 2: two of the six expressions (1 joy, 2 sadness, 3 anger, 4 fear, 5 disgust, 6 surprise)
/// with intensities 0-63.
struct FapExpression {
  int select1 = 0, intensity1 = 0, select2 = 0, intensity2 = 0, init_face = 0, def = 0;
};

/// One frame as transmitted: the mask and the values of the FAPs it sets.
struct FapFrame {
  std::bitset<kFapCount> mask;            // bit n-1: FAP n is set
  std::array<double, kFapCount> value{};  // FAP n at n-1 (3-68; units of its FAPU / 1024 or AU)
  FapViseme viseme;                       // FAP 1
  FapExpression expression;               // FAP 2
};

struct FapSequence {
  std::string version = "2.1";
  std::string name = "facecast";
  double fps = 25;
  std::vector<FapFrame> frames;  // one per frame, every frame listed
};

/// Bounds on a file from outside.
struct FapLimits {
  std::size_t max_bytes = 64u << 20;
  int max_frames = 1 << 17;   // 73 min at 30 fps; a frame costs ~600 bytes parsed
  double max_seconds = 3600;  // frames / fps
  double max_value = 1e6;     // |low-level FAP|, in units (1e6 = 1000 FAPUs; 10 rad in AU)
};

/// Parses an FBA ASCII FAP file; throws Error "<what>:<line>: <problem>" on anything malformed or
/// out of bounds. Frames the file skips repeat the previous one (see above).
FapSequence parse_fap(std::string_view text, std::string_view what, const FapLimits& limits = {});
/// The file (integer values, as the standard codes them).
std::string to_fap_text(const FapSequence& sequence);

/// The face animation parameter units of a rig, in its length unit.
struct Fapu {
  double es0 = 0, ens0 = 0, mns0 = 0, mw0 = 0, irisd0 = 0;
};

/// configs/anim/fap.json: the low-level FAPs a rig can show, each the displacement of a feature
/// point (the mean of some landmarks) along the face's x (the subject's left), y (up) or z
/// (forward) axis; the MPEG-4 viseme numbers of each viseme set; the decoder's prior weight.
struct FapTable {
  struct Feature {
    int fap = 0;
    std::string name;
    enum class Unit { kES, kENS, kMNS, kMW, kIRISD } unit = Unit::kMNS;
    std::vector<int> points;  // landmark indices 0-67
    int axis = 1;             // 0 x, 1 y, 2 z
    double sign = 1;
  };
  std::vector<Feature> features;
  /// The MPEG-4 viseme number of every viseme name of the three sets.
  std::map<std::string, int, std::less<>> viseme_numbers;
  std::array<std::string, 6> expressions;  // the expression names of FAP 2 selects 1-6
  double prior_weight = 1e-3;              // lambda, relative to the mean diagonal of B^T B
  double measured_threshold = 4;           // a FAP moves less than this (units) on every shape:
                                           // the rig cannot show it, the file leaves it out
};

/// Reads configs/anim/fap.json; throws Error naming the field when invalid.
FapTable load_fap_table();

/// A rig measured at its feature points.
class FapRig {
 public:
  /// `landmarks`: the rig's vertex of each iBUG landmark (-1 where unknown; features on unknown
  /// landmarks are left out). Throws Error when the landmarks that define the units are missing.
  FapRig(const rig::Rig& rig, std::span<const int, kFeaturePoints> landmarks,
         const FapTable& table = load_fap_table());

  const Fapu& fapu() const { return fapu_; }
  const std::vector<std::string>& shape_names() const { return shapes_; }
  const FapTable& table() const { return table_; }
  /// Whether the rig's shapes move FAP `fap` (1-68); head FAPs 48-50 always are.
  bool measured(int fap) const;
  /// FAPs 3-68 units per unit weight of shape `s`.
  double basis(int fap, int s) const;

  /// The low-level FAPs of weights and a head pose; sets the mask of every measured FAP.
  void encode(std::span<const float> weights, const rig::BodyPose& head, FapFrame& out) const;

 private:
  FapTable table_;
  std::vector<std::string> shapes_;
  Fapu fapu_;
  std::vector<double> basis_;  // kFapCount x shapes, row-major
  std::bitset<kFapCount> measured_;
};

/// A motion as low-level FAPs at `fps`: its weights and head through `rig` (which must have the
/// motion's shapes), ceil(duration * fps) frames.
FapSequence to_fap(const rig::Motion& motion, const FapRig& rig, double fps,
                   std::string name = "facecast");
/// The same with the high level of a performance: FAP 1 from its viseme channels (the two
/// strongest and their ratio), FAP 2 from its expressions (the two strongest).
FapSequence to_fap(const Performance& performance, const FapRig& rig, double fps,
                   std::string name = "facecast");

/// A FAP sequence driving a rig: every frame solved for weights once, sampled with linear
/// interpolation between frames. `mapping` (the rig's tables, for FAP 1 and 2) must have the same
/// shapes as `rig`.
class FapMotion final : public rig::Motion {
 public:
  FapMotion(const FapSequence& sequence, const FapRig& rig, const Mapping& mapping);

  double duration() const override;
  const std::vector<std::string>& shape_names() const override { return shapes_; }
  void sample(double t, std::span<float> weights, rig::BodyPose* head = nullptr) const override;
  int frame_count() const { return frames_; }
  double fps() const { return fps_; }

 private:
  std::vector<std::string> shapes_;
  double fps_ = 25;
  int frames_ = 0;
  std::vector<float> weights_;  // frames x shapes
  std::vector<rig::BodyPose> head_;
};

}  // namespace facecast::anim
