#pragma once
// Steps 1-4 of the animation chain (animation.hpp), each a pure function: values in, values out.
// Performance calls them once per utterance and keeps their results; sample() evaluates them.
#include <array>
#include <span>
#include <string>
#include <vector>

#include "facecast/rig/motion.hpp"
#include "facecast/viseme/utterance.hpp"

namespace facecast::anim {

struct AnimOptions;

/// The cubic Hermite curve on u in [0, 1] from a0 to a1 with start tangent g (per unit of u) and
/// end tangent 0: (2u^3 - 3u^2 + 1) a0 + (-2u^3 + 3u^2) a1 + (u^3 - 2u^2 + u) g.
/// See docs/algorithms.md#expression-transitions.
float hermite(float a0, float a1, float g, double u);
/// Its derivative with respect to u.
float hermite_slope(float a0, float a1, float g, double u);

// ---- 1. Visemes -> keys (coarticulation). See docs/algorithms.md#coarticulation. -------------

/// A viseme event as a dominance source.
struct DominanceEvent {
  int channel = -1;  // index into the set's viseme names; -1 for the pause viseme (rest)
  double start = 0, end = 0, centre = 0;
  double alpha = 1;     // dominance strength: closure_alpha for closure visemes, 1 others, 0.5 rest
  double strength = 1;  // the viseme event's strength: scales its channel's share, not alpha
};

/// One event per viseme of `visemes`. `names` are the set's viseme names in channel order (the
/// pause viseme first); `closure` the channels whose lips must meet. Throws Error naming a viseme
/// that is not in `names` (`set` names the set in that message).
std::vector<DominanceEvent> dominance_events(const std::vector<viseme::VisemeEvent>& visemes,
                                             const std::vector<std::string>& names,
                                             const std::vector<int>& closure, double closure_alpha,
                                             viseme::VisemeSet set);

/// The viseme channel values at time t, one per channel: every event's dominance
/// D_j(t) = alpha_j exp(-theta |t - c_j|) (theta_anticipation before c_j, theta_carryover after
/// it), normalised over all events and scaled by `articulation`. When `own` is a closure channel
/// it is set to 1 and the others scaled by what it lacked (the lips meet whatever the neighbours).
std::vector<float> dominance_blend(std::span<const DominanceEvent> events, int channels,
                                   const std::vector<int>& closure, const AnimOptions& options,
                                   double t, int own);

/// A key of the viseme curve: the channel values at time t.
struct ChannelKey {
  double t = 0;
  std::vector<float> value;  // per viseme channel
};

/// The keys, sorted by time: rest (all zero) before the first and after the last sounding viseme
/// (rest_ramp away), a rest plateau inside every pause of at least rest_pause, and a
/// dominance_blend() key at each sounding viseme's centre.
std::vector<ChannelKey> viseme_keys(std::span<const DominanceEvent> events, int channels,
                                    const std::vector<int>& closure, const AnimOptions& options);

// ---- 2. Between keys: the Hermite curve with zero end tangents. -------------------------------

/// The channel values at t: the first key's before it, the last key's after it, hermite() with
/// zero tangents between neighbouring keys; zeros when there are no keys.
std::vector<float> sample_keys(const std::vector<ChannelKey>& keys, std::size_t channels, double t);

// ---- 3. Expressions. See docs/algorithms.md#expression-transitions. --------------------------

/// A Hermite ramp from (t0, v0, start tangent g) to (t0 + T, v1), then a hold at v1.
struct ExpressionSegment {
  double t0 = 0, T = 0;
  float v0 = 0, v1 = 0, g = 0;
};

/// The ramp of a tag starting at `start` towards `target` over T seconds, after `previous` (the
/// expression's last segment, or nullptr). The three start cases: from 0 (the first tag of the
/// name); from the previous target (the previous ramp finished); from the interrupted ramp's value
/// and tangent (rescaled to this ramp's length), so the curve stays C1.
ExpressionSegment next_ramp(const ExpressionSegment* previous, double start, double T,
                            float target);

/// One expression's curve (segments in time order).
struct ExpressionCurve {
  std::string name;
  std::vector<ExpressionSegment> segments;
};

/// One curve per expression name, in order of first appearance (tags sorted by start): next_ramp()
/// per tag (intensity / 63 clamped to [0, 1], ramp T), then a release to 0 over `tail` from
/// `release_at` (the speech's end), from where the last ramp is then.
std::vector<ExpressionCurve> expression_curves(const std::vector<viseme::ExpressionEvent>& tags,
                                               double release_at, double tail);

/// The curve's value at t, in [0, 1] (0 before its first segment).
float sample_curve(const ExpressionCurve& curve, double t);

// ---- 4. Idle life. ---------------------------------------------------------------------------

/// Blink times, saccade targets and head-motion phases drawn from options.seed (splitmix64, the
/// same on every platform).
/// A stretch of speech between pauses (s), with its accent: the onset of its longest word when
/// that word is long for the phrase (over 1.4 times its words' mean length), else -1.
struct Span {
  double start = 0, end = 0;
  double accent = -1;
};

/// The speech's phrases: its words (else its visemes other than sil) joined across gaps shorter
/// than `pause` seconds.
std::vector<Span> speech_spans(const viseme::Utterance& u, double pause);

/// A head accent: a nod (pitch down and back over 0.45 s) with a small tilt, at `t`.
struct Nod {
  double t = 0;
  float strength = 1;  // of head_nod
  float tilt = 0;      // roll, of head_nod (alternating sides)
};

struct IdleLife {
  double duration = 0;         // of the performance: gaze and head return to rest by then
  std::vector<double> blinks;  // when each blink starts closing
  std::vector<std::pair<double, std::array<float, 2>>> gazes;  // saccade targets (t, {x, y})
  std::array<double, 3> head_phase{};                          // of the yaw, pitch, roll sines
  std::array<double, 2> body_phase{};                          // of the breath and the lean
  std::vector<Span> phrases;  // speech: the head moves more while it lasts, settles in pauses
  std::vector<Nod> nods;      // at each phrase's start and its accented words
};

/// Blinks every blink_interval_min..max seconds, a new gaze target every 0.7-2.2 s (x in [-1, 1],
/// y in [-0.6, 0.6], back to {0, 0} 0.3 s before the end), random sine phases; a nod at each
/// phrase's start (strength 1) and at its accent (0.6), tilting to alternate sides.
IdleLife idle_life(double duration, const std::vector<Span>& phrases, const AnimOptions& options);

/// Blink closure at t in [0, 1]: close over blink_close, hold blink_hold, open over blink_open.
float blink_at(const IdleLife& idle, const AnimOptions& options, double t);

/// Gaze at t ({x, y}, +x to the subject's left, +y up): a 40 ms smooth move to each target.
std::array<float, 2> gaze_at(const IdleLife& idle, double t);

/// Head pose at t: slow sums of sines of amplitude head_motion (half of it outside the phrases:
/// the head settles in pauses), faded in and out over 0.5 s, plus the nods.
rig::BodyPose head_at(const IdleLife& idle, const AnimOptions& options, double t);

/// The breath at t in [0, breath_depth]: at rest a cosine of breath_rate; with speech a breath
/// in over the 0.45 s before each phrase, out through it (0.15 a second, to 0.2 at least), the
/// level held in short pauses and back to the resting cycle within a second after the last
/// phrase; faded in and out over 0.5 s at the ends.
float breath_at(const IdleLife& idle, const AnimOptions& options, double t);

/// The whole idle pose at t: head_at, the breath, a slow weight shift (two sines of peak
/// body_lean, faded at the ends) and a shrug of `shrug` over 0.6 s at each accented word.
rig::BodyPose body_at(const IdleLife& idle, const AnimOptions& options, double t);

// ---- 5. Mixing (in Performance::sample). ------------------------------------------------------

/// How much of the expression's mouth-opening shapes (the table's closure_damped) is kept at a
/// mouth closure of `closure` (the closure channels' sum, clamped to [0, 1]): 1 - smoothstep of
/// (closure - 0.2) / 0.7, so only a closure on its way to full contact damps (coarticulated
/// traces of a /p/ do not).
float closure_keep(float closure);

}  // namespace facecast::anim
