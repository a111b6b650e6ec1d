#pragma once
// From timed viseme and expression events to blendshape weights per frame.
//
// The chain (steps 1-4 are the pure functions of animation_steps.hpp; Performance runs them once
// per utterance and mixes their results in sample()):
//   1. Visemes -> keys. Every viseme event becomes a key at its centre whose value is a vector over
//      the viseme channels, blended from the neighbouring events by Cohen-Massaro dominance
//      D_j(t) = alpha_j exp(-theta |t - c_j|) (normalized), so neighbours colour each other
//      (coarticulation). Closure visemes (the mapping table's "closure" list: bpm/f, PP/FF) have a
//      high alpha and their own channel at full value: the lips do close on /p/ and /f/. Long
//      pauses get rest keys so the face is still. See docs/algorithms.md#coarticulation.
//   2. Between keys the value follows a cubic Hermite curve with zero end tangents.
//   3. Expressions: one curve per expression name, Hermite ramps over the tag's T with three start
//      cases (from 0, from the previous target, or from the interrupted value and tangent),
//      released over the tail after the speech. See docs/algorithms.md#expression-transitions.
//   4. Idle life (optional): blinks at random intervals and small eye and head motion, seeded so a
//      run is reproducible.
//   5. Mixing: viseme channels and expressions map to the rig's blendshapes through the tables in
//      configs/anim/ (ARKit names incl. the ICT _L/_R variant, Oculus viseme morphs); the two
//      contributions mix per shape by the max rule, except that mouth closure damps the
//      expression's mouth-opening shapes (a smile must not keep the lips apart on /p/); clamp
//      [0,1].
//
// Cost: building a Performance is O(events); sample() is O(#channels + #mapped shape entries)
// after an O(log keys) search, about a microsecond, so a server can sample each frame on demand.
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "facecast/anim/animation_steps.hpp"
#include "facecast/rig/motion.hpp"
#include "facecast/viseme/utterance.hpp"

namespace facecast::anim {

/// Defaults mirrored in configs/anim/animation.json.
struct AnimOptions {
  // Coarticulation
  double theta_anticipation = 30.0;  // 1/s, dominance decay before a viseme's centre
  double theta_carryover = 22.0;     // 1/s, after it
  double closure_alpha = 6.0;        // dominance of closure visemes (others 1)
  double articulation = 1.0;         // scales every viseme key (0.8 = lazier speech)
  double rest_pause = 0.25;          // pauses (sil) at least this long get rest keys (s)
  double rest_ramp = 0.12;           // time to reach and leave rest in such a pause (s)
  double tail = 0.3;                 // after the utterance, time to settle to neutral (s)
  // Idle life
  bool idle = true;
  double blink_interval_min = 2.0;  // s
  double blink_interval_max = 5.5;  // s
  double blink_close = 0.07;        // s to close
  double blink_hold = 0.03;         // s closed
  double blink_open = 0.16;         // s to open
  double eye_motion = 0.12;         // peak eyeLook* weight of small saccades
  double head_motion = 0.035;       // peak head rotation (radians)
  double head_nod = 0.05;           // nod at each phrase's start (radians; accents 60 %, tilt 40 %)
  // Idle body (rig::BodyPose's breath, lean and shrug; 0 turns each off)
  double breath_rate = 0.25;  // breaths per second at rest (speech breathes by its phrases)
  double breath_depth = 1.0;  // peak of the breath channel
  double body_lean = 0.02;    // peak weight shift (radians of the spine's lean)
  double shrug = 0.4;         // the shoulders' rise at an accented word
  uint32_t seed = 1;          // idle randomness
};

/// Reads configs/anim/animation.json; throws Error naming the field when invalid.
AnimOptions load_anim_options();

/// How viseme channels and expressions drive a rig's blendshapes.
/// for_rig() picks the table by the rig's shape names: Oculus viseme morphs (viseme_aa ...) ->
/// configs/anim/visemes_oculus.json; ARKit names -> configs/anim/visemes_arkit.json, with
/// Left/Right mapped to _L/_R where the rig uses those (ICT FaceKit); VRM expression presets (aa ih
/// ou ee oh, no jawOpen) -> configs/anim/visemes_vrm.json. Expressions come from
/// configs/anim/expressions_vrm.json for VRM, configs/anim/expressions_arkit.json otherwise. Table
/// entries whose shape the rig lacks are dropped; throws Error when nothing at all maps (not a face
/// rig) and names the file and key of a bad table.
class Mapping {
 public:
  static Mapping for_rig(const std::vector<std::string>& shape_names);

  const std::vector<std::string>& shape_names() const { return shapes_; }
  /// Which table was chosen ("arkit" | "oculus" | "vrm"): by what the avatar has (Oculus visemes,
  /// ARKit or ICT FaceKit names, VRM expression presets), for logs and `rig info`.
  const std::string& table() const { return table_; }

  struct Entry {
    int shape;
    float weight;
  };
  /// One row per viseme of a set (index = position in the set's list, as in
  /// configs/viseme/viseme_sets.json; "sil" maps to nothing).
  const std::vector<std::vector<Entry>>& visemes(viseme::VisemeSet set) const;
  const std::vector<std::string>& viseme_names(viseme::VisemeSet set) const;
  /// Expression rows by name; nullptr for an unknown name.
  const std::vector<Entry>* expression(const std::string& name) const;
  /// Channels of `set` (indices into viseme_names(set)) whose lips must meet: the table's
  /// "closure" list (MPEG-4 takes the Oculus channels, its visemes being the Oculus ones renamed).
  const std::vector<int>& closure_channels(viseme::VisemeSet set) const;
  /// Shapes that mouth closure damps in the expression contribution.
  const std::vector<int>& closure_damped() const { return closure_damped_; }
  /// What the avatar can show: every viseme channel ("viseme.<set>.<name>"), expression
  /// ("expression.<name>"), "blink" and "eye_look", with whether any of its shapes drive it.
  struct Channel {
    std::string name;
    bool shown;
  };
  std::vector<Channel> channels() const;
  /// Blink and eye-look shapes for idle life (-1 when absent).
  int blink_left = -1, blink_right = -1;
  int look_up[2] = {-1, -1}, look_down[2] = {-1, -1}, look_in[2] = {-1, -1}, look_out[2] = {-1, -1};

 private:
  std::vector<std::string> shapes_;
  std::string table_;
  std::vector<std::vector<Entry>> sets_[3];
  std::vector<std::string> set_names_[3];
  std::vector<int> closure_[3];
  std::vector<std::pair<std::string, std::vector<Entry>>> expressions_;
  std::vector<int> closure_damped_;
};

/// One utterance compiled into curves, ready to sample at any time. A value type (it keeps its own
/// copy of the mapping rows it uses), so a stream can own one.
class Performance final : public rig::Motion {
 public:
  Performance(const viseme::Utterance& utterance, const Mapping& mapping,
              const AnimOptions& options = {});

  /// Seconds from the start of the audio to when the face is back at rest (utterance + tail).
  double duration() const override { return duration_; }
  /// Length of the speech itself (the audio length when there is audio).
  double speech_duration() const { return speech_duration_; }
  /// Frames at `fps` covering [0, duration()): ceil(duration * fps).
  int frame_count(double fps) const;

  /// Weights at time `t` (seconds from the start of the audio), one per rig shape in the mapping's
  /// order; `weights.size()` must equal the shape count (throws Error otherwise). `head` (optional)
  /// receives the idle head pose. Thread-safe (const).
  void sample(double t, std::span<float> weights, rig::BodyPose* head = nullptr) const override;

  /// The rig's shape names, in the order sample() writes them.
  const std::vector<std::string>& shape_names() const override { return mapping_.shape_names(); }

  /// The viseme names of the utterance's set, in channel order ("sil" first).
  const std::vector<std::string>& viseme_names() const { return mapping_.viseme_names(set_); }

  /// The viseme channel values at `t` (for tests and the timeline), one per viseme of the set.
  std::vector<float> viseme_channels(double t) const;
  /// The expression intensity (0..1) of `name` at `t`.
  float expression_value(const std::string& name, double t) const;

 private:
  struct MappedCurve {
    ExpressionCurve curve;
    std::vector<Mapping::Entry> entries;  // the expression's row of the mapping
  };

  Mapping mapping_;
  viseme::VisemeSet set_;
  AnimOptions options_;
  double duration_ = 0, speech_duration_ = 0;
  std::vector<ChannelKey> keys_;          // step 1
  std::vector<MappedCurve> expressions_;  // step 3
  IdleLife idle_;                         // step 4 (empty when options_.idle is off)
};

/// Weights of a whole performance at a fixed rate: frames x shapes, row-major float32, frame f at
/// pts f / fps seconds from the start of the audio.
struct WeightTrack {
  std::vector<std::string> shapes;
  double fps = 60;
  int frames = 0;
  std::vector<float> weights;       // frames * shapes.size()
  std::vector<rig::BodyPose> head;  // one per frame
  std::span<const float> frame(int f) const {
    return {weights.data() + static_cast<size_t>(f) * shapes.size(), shapes.size()};
  }
};

/// `until` > 0 bakes ceil(until * fps) frames (a video covering just the audio: speech_duration());
/// otherwise ceil(duration() * fps) (a Performance's frame_count(fps)).
WeightTrack bake(const rig::Motion& motion, double fps, double until = 0);

/// A smooth return to rest from `from` (e.g. the weights when a stream is cancelled): hermite()
/// with zero tangents, `t` seconds into a `duration`-long fade. Writes `out`.
void fade_to_rest(std::span<const float> from, double t, double duration, std::span<float> out);

/// JSON {fps, frames, shapes:[...], weights:[[...], ...], head:[[yaw,pitch,roll], ...]}.
std::string to_json(const WeightTrack& track);
/// Binary: "FCWT" magic, u32 version 1, u32 shapes, u32 frames, f64 fps, then each shape name as
/// u16 length + UTF-8, then frames x shapes float32 little-endian.
std::string to_binary(const WeightTrack& track);

}  // namespace facecast::anim
