// Viseme and expression events -> blendshape weights. See animation.hpp for the chain.
#include "facecast/anim/animation.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>

#include "facecast/core/config.hpp"
#include "facecast/core/config_reader.hpp"
#include "facecast/core/error.hpp"

namespace facecast::anim {

AnimOptions load_anim_options() {
  ConfigReader c = ConfigReader::open(config_path("anim/animation.json"));
  AnimOptions o;
  c.read("theta_anticipation", o.theta_anticipation)
      .read("theta_carryover", o.theta_carryover)
      .read("closure_alpha", o.closure_alpha)
      .read("articulation", o.articulation)
      .read("rest_pause", o.rest_pause)
      .read("rest_ramp", o.rest_ramp)
      .read("tail", o.tail);
  c.read("idle", o.idle)
      .read("blink_interval_min", o.blink_interval_min)
      .read("blink_interval_max", o.blink_interval_max)
      .read("blink_close", o.blink_close)
      .read("blink_hold", o.blink_hold)
      .read("blink_open", o.blink_open)
      .read("eye_motion", o.eye_motion)
      .read("head_motion", o.head_motion)
      .read("head_nod", o.head_nod)
      .read("breath_rate", o.breath_rate)
      .read("breath_depth", o.breath_depth)
      .read("body_lean", o.body_lean)
      .read("shrug", o.shrug)
      .read("seed", o.seed);
  c.reject_unknown();
  if (!(o.breath_rate >= 0 && o.breath_rate <= 2)) c.fail("breath_rate", "must be in [0, 2]");
  if (!(o.breath_depth >= 0 && o.breath_depth <= 1)) c.fail("breath_depth", "must be in [0, 1]");
  if (!(o.shrug >= 0 && o.shrug <= 1)) c.fail("shrug", "must be in [0, 1]");
  if (!(std::abs(o.body_lean) <= 0.2)) c.fail("body_lean", "must be within 0.2 radians");
  if (!(o.blink_interval_min > 0 && o.blink_interval_max >= o.blink_interval_min))
    c.fail("blink_interval_min", "must be > 0 and <= blink_interval_max");
  if (!(o.theta_anticipation > 0 && o.theta_carryover > 0 && o.closure_alpha > 0))
    c.fail(
        "dominance parameters (theta_anticipation, theta_carryover, closure_alpha) must be "
        "positive");
  return o;
}

// ---------------------------------------------------------------------------------------------
// Performance: steps 1-4 once (animation_steps.hpp), the mixing (step 5) per sample.

Performance::Performance(const viseme::Utterance& u, const Mapping& mapping,
                         const AnimOptions& options)
    : mapping_(mapping), set_(u.set), options_(options) {
  const auto& names = mapping_.viseme_names(set_);
  const auto& closure = mapping_.closure_channels(set_);
  const std::vector<DominanceEvent> events =
      dominance_events(u.visemes, names, closure, options_.closure_alpha, set_);
  double last_end = 0;
  for (const auto& e : events) last_end = std::max(last_end, e.end);
  speech_duration_ = std::max(u.duration, last_end);
  duration_ = speech_duration_ + options_.tail;

  keys_ = viseme_keys(events, static_cast<int>(names.size()), closure, options_);
  for (auto& curve : expression_curves(u.expressions, speech_duration_, options_.tail)) {
    const auto* row = mapping_.expression(curve.name);
    expressions_.push_back({std::move(curve), row ? *row : std::vector<Mapping::Entry>{}});
  }
  if (options_.idle) idle_ = idle_life(duration_, speech_spans(u, options_.rest_pause), options_);
}

int Performance::frame_count(double fps) const {
  if (!(fps > 0)) throw Error("fps must be positive");
  return static_cast<int>(std::ceil(duration_ * fps - 1e-9));
}

std::vector<float> Performance::viseme_channels(double t) const {
  return sample_keys(keys_, mapping_.viseme_names(set_).size(), t);
}

float Performance::expression_value(const std::string& name, double t) const {
  for (const auto& c : expressions_)
    if (c.curve.name == name) return sample_curve(c.curve, t);
  return 0.0f;
}

void Performance::sample(double t, std::span<float> weights, rig::BodyPose* head) const {
  const auto& shapes = mapping_.shape_names();
  if (weights.size() != shapes.size())
    throw Error("sample: " + std::to_string(weights.size()) + " weights for a rig with " +
                std::to_string(shapes.size()) + " shapes");
  std::fill(weights.begin(), weights.end(), 0.0f);

  // Visemes: a convex blend of viseme poses (channels from the key curve).
  const std::vector<float> ch = viseme_channels(t);
  const auto& rows = mapping_.visemes(set_);
  float closure = 0;
  for (const int c : mapping_.closure_channels(set_)) closure += ch[c];
  closure = std::clamp(closure, 0.0f, 1.0f);
  for (size_t c = 0; c < ch.size(); ++c)
    if (ch[c] != 0)
      for (const auto& e : rows[c]) weights[e.shape] += ch[c] * e.weight;

  // Expressions, summed, then mixed by the max rule; closure damps the mouth-opening shapes.
  if (!expressions_.empty()) {
    thread_local std::vector<float> expr;
    expr.assign(shapes.size(), 0.0f);
    for (const auto& c : expressions_) {
      const float v = sample_curve(c.curve, t);
      if (v != 0)
        for (const auto& e : c.entries) expr[e.shape] += v * e.weight;
    }
    const float keep = closure_keep(closure);
    for (const int s : mapping_.closure_damped()) expr[s] *= keep;
    for (size_t s = 0; s < shapes.size(); ++s) weights[s] = std::max(weights[s], expr[s]);
  }

  if (head) *head = {};
  if (options_.idle) {
    // Blinks, by the max rule with whatever else drives the lids.
    const float blink = blink_at(idle_, options_, t);
    for (const int s : {mapping_.blink_left, mapping_.blink_right})
      if (s >= 0) weights[s] = std::max(weights[s], blink);

    // Saccades: +x looks to the subject's left: the left eye out, the right eye in.
    const auto [gx, gy] = gaze_at(idle_, t);
    const auto amp = static_cast<float>(options_.eye_motion);
    const auto add = [&](int s, float v) {
      if (s >= 0 && v > 0) weights[s] = std::max(weights[s], v * amp);
    };
    add(mapping_.look_out[0], gx);
    add(mapping_.look_in[1], gx);
    add(mapping_.look_in[0], -gx);
    add(mapping_.look_out[1], -gx);
    add(mapping_.look_up[0], gy);
    add(mapping_.look_up[1], gy);
    add(mapping_.look_down[0], -gy);
    add(mapping_.look_down[1], -gy);

    if (head) *head = body_at(idle_, options_, t);
  }
  for (float& w : weights) w = std::clamp(w, 0.0f, 1.0f);
}

// ---------------------------------------------------------------------------------------------

WeightTrack bake(const rig::Motion& motion, double fps, double until) {
  if (!(fps > 0)) throw Error("fps must be positive");
  WeightTrack track;
  track.shapes = motion.shape_names();
  track.fps = fps;
  track.frames = static_cast<int>(std::ceil((until > 0 ? until : motion.duration()) * fps - 1e-9));
  track.weights.resize(static_cast<size_t>(track.frames) * track.shapes.size());
  track.head.resize(track.frames);
  for (int f = 0; f < track.frames; ++f)
    motion.sample(
        f / fps,
        {track.weights.data() + static_cast<size_t>(f) * track.shapes.size(), track.shapes.size()},
        &track.head[f]);
  return track;
}

void fade_to_rest(std::span<const float> from, double t, double duration, std::span<float> out) {
  if (from.size() != out.size()) throw Error("fade_to_rest: size mismatch");
  const float k =
      duration <= 0 ? 0.0f : hermite(1.0f, 0.0f, 0.0f, std::clamp(t / duration, 0.0, 1.0));
  for (size_t i = 0; i < from.size(); ++i) out[i] = from[i] * k;
}

std::string to_json(const WeightTrack& track) {
  nlohmann::json j;
  j["fps"] = track.fps;
  j["frames"] = track.frames;
  j["shapes"] = track.shapes;
  auto& w = j["weights"] = nlohmann::json::array();
  auto& h = j["head"] = nlohmann::json::array();
  auto& b = j["body"] = nlohmann::json::array();
  for (int f = 0; f < track.frames; ++f) {
    const auto row = track.frame(f);
    nlohmann::json r = nlohmann::json::array();
    for (const float v : row) r.push_back(std::round(v * 1e5f) / 1e5f);
    w.push_back(std::move(r));
    const auto& p = track.head[f];
    h.push_back({p.yaw, p.pitch, p.roll});
    b.push_back({p.breath, p.lean, p.shrug});
  }
  return j.dump();
}

std::string to_binary(const WeightTrack& track) {
  std::string out("FCWT");
  const auto put = [&](const auto& v) {
    char b[sizeof(v)];
    std::memcpy(b, &v, sizeof(v));  // little-endian hosts only (x86-64, aarch64)
    out.append(b, sizeof(v));
  };
  put(uint32_t{1});
  put(static_cast<uint32_t>(track.shapes.size()));
  put(static_cast<uint32_t>(track.frames));
  put(track.fps);
  for (const auto& s : track.shapes) {
    put(static_cast<uint16_t>(s.size()));
    out += s;
  }
  out.append(reinterpret_cast<const char*>(track.weights.data()),
             track.weights.size() * sizeof(float));
  return out;
}

}  // namespace facecast::anim
