// Viseme and expression events -> blendshape weights. See animation.hpp for the chain.
#include "facecast/anim/animation.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <nlohmann/json.hpp>

#include "facecast/core/config.hpp"
#include "facecast/core/error.hpp"

namespace facecast::anim {
namespace {

using viseme::VisemeSet;

int set_index(VisemeSet set) {
  return static_cast<int>(set);
}

// The seed's Hermite curve on u in [0,1]: start a0, end a1, start tangent g, end tangent 0.
float hermite(float a0, float a1, float g, double u) {
  const double u2 = u * u, u3 = u2 * u;
  return static_cast<float>((2 * u3 - 3 * u2 + 1) * a0 + (-2 * u3 + 3 * u2) * a1 +
                            (u3 - 2 * u2 + u) * g);
}
// Its derivative with respect to u.
float hermite_slope(float a0, float a1, float g, double u) {
  const double u2 = u * u;
  return static_cast<float>((6 * u2 - 6 * u) * a0 + (-6 * u2 + 6 * u) * a1 +
                            (3 * u2 - 4 * u + 1) * g);
}
double smooth(double u) {
  return u <= 0 ? 0 : u >= 1 ? 1 : u * u * (3 - 2 * u);
}

// splitmix64: a small, portable, seeded generator (the idle motion must be the same everywhere).
struct Rng {
  uint64_t s;
  double uniform(double lo, double hi) {
    uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return lo + (hi - lo) * static_cast<double>(z >> 11) * 0x1.0p-53;
  }
};

// Rig shapes that a table name drives: the name itself; else Left/Right -> _L/_R (ICT FaceKit);
// else an unsided name split over name_L and name_R.
std::vector<int> resolve(const std::vector<std::string>& shapes, const std::string& name) {
  const auto find = [&](const std::string& n) {
    const auto it = std::find(shapes.begin(), shapes.end(), n);
    return it == shapes.end() ? -1 : static_cast<int>(it - shapes.begin());
  };
  if (const int i = find(name); i >= 0) return {i};
  for (const auto& [side, suffix] : {std::pair{"Left", "_L"}, std::pair{"Right", "_R"}}) {
    const std::string s = side;
    if (name.size() > s.size() && name.ends_with(s)) {
      const int i = find(name.substr(0, name.size() - s.size()) + suffix);
      return i >= 0 ? std::vector<int>{i} : std::vector<int>{};
    }
  }
  std::vector<int> out;
  for (const char* suffix : {"_L", "_R"})
    if (const int i = find(name + suffix); i >= 0) out.push_back(i);
  return out;
}

std::vector<Mapping::Entry> resolve_row(const std::vector<std::string>& shapes,
                                        const nlohmann::json& row, const std::string& where) {
  if (!row.is_object()) throw Error(where + ": expected an object of shape weights");
  std::vector<Mapping::Entry> out;
  for (const auto& [name, w] : row.items()) {
    if (!w.is_number()) throw Error(where + "." + name + ": expected a number");
    for (const int s : resolve(shapes, name)) out.push_back({s, w.get<float>()});
  }
  return out;
}

}  // namespace

AnimOptions load_anim_options() {
  const auto path = config_path("anim/animation.json");
  const nlohmann::json j = load_json(path);
  AnimOptions o;
  const auto get = [&](const char* key, auto& value) {
    if (!j.contains(key)) throw Error(path.string() + ": missing field '" + key + "'");
    try {
      j.at(key).get_to(value);
    } catch (const nlohmann::json::exception&) {
      throw Error(path.string() + ": field '" + key + "' has the wrong type");
    }
  };
  get("theta_anticipation", o.theta_anticipation);
  get("theta_carryover", o.theta_carryover);
  get("closure_alpha", o.closure_alpha);
  get("articulation", o.articulation);
  get("rest_pause", o.rest_pause);
  get("rest_ramp", o.rest_ramp);
  get("tail", o.tail);
  get("idle", o.idle);
  get("blink_interval_min", o.blink_interval_min);
  get("blink_interval_max", o.blink_interval_max);
  get("blink_close", o.blink_close);
  get("blink_hold", o.blink_hold);
  get("blink_open", o.blink_open);
  get("eye_motion", o.eye_motion);
  get("head_motion", o.head_motion);
  get("seed", o.seed);
  if (!(o.blink_interval_min > 0 && o.blink_interval_max >= o.blink_interval_min))
    throw Error(path.string() + ": field 'blink_interval_min' must be > 0 and <= the max");
  if (!(o.theta_anticipation > 0 && o.theta_carryover > 0 && o.closure_alpha > 0))
    throw Error(path.string() + ": dominance parameters must be positive");
  return o;
}

// ---------------------------------------------------------------------------------------------
// Mapping

Mapping Mapping::for_rig(const std::vector<std::string>& shape_names) {
  Mapping m;
  m.shapes_ = shape_names;
  const auto has_oculus = std::count_if(shape_names.begin(), shape_names.end(),
                                        [](auto& n) { return n.starts_with("viseme_"); }) >= 10;
  m.table_ = has_oculus ? "oculus" : "arkit";
  const auto table_path = config_path("anim/visemes_" + m.table_ + ".json");
  const auto table = load_json(table_path);
  const auto sets = load_json(config_path("viseme/viseme_sets.json"));
  const std::string where = table_path.string();

  // Viseme names per set; MPEG-4 rows are the Oculus rows renamed.
  m.set_names_[set_index(VisemeSet::kZh15)] = sets.at("zh15").get<std::vector<std::string>>();
  m.set_names_[set_index(VisemeSet::kOculus)] = sets.at("oculus").get<std::vector<std::string>>();
  for (const auto& oc : m.set_names_[set_index(VisemeSet::kOculus)])
    m.set_names_[set_index(VisemeSet::kMpeg4)].push_back(
        sets.at("mpeg4_from_oculus").at(oc).get<std::string>());

  size_t mapped = 0;
  for (const VisemeSet set : {VisemeSet::kZh15, VisemeSet::kOculus}) {
    const std::string set_name(viseme::to_string(set));
    const auto& rows = table.at("visemes").at(set_name);
    for (const auto& v : m.set_names_[set_index(set)]) {
      if (!rows.contains(v)) throw Error(where + ": visemes." + set_name + " lacks '" + v + "'");
      m.sets_[set_index(set)].push_back(
          resolve_row(shape_names, rows.at(v), where + ": visemes." + set_name + "." + v));
      mapped += m.sets_[set_index(set)].back().size();
    }
  }
  m.sets_[set_index(VisemeSet::kMpeg4)] = m.sets_[set_index(VisemeSet::kOculus)];
  if (mapped == 0)
    throw Error("the rig has no blendshape that " + where +
                    " maps a viseme to (expected ARKit names or Oculus viseme_* morphs)",
                ErrorCode::kUnsupported);

  const auto expr_path = config_path("anim/expressions_arkit.json");
  const auto expr_table = load_json(expr_path);
  for (const auto& [name, row] : expr_table.at("expressions").items())
    m.expressions_.emplace_back(
        name, resolve_row(shape_names, row, expr_path.string() + ": expressions." + name));

  for (const auto& name : table.at("closure_damped"))
    for (const int s : resolve(shape_names, name.get<std::string>()))
      m.closure_damped_.push_back(s);

  const auto one = [&](const std::string& n) {
    const auto r = resolve(shape_names, n);
    return r.empty() ? -1 : r.front();
  };
  m.blink_left = one("eyeBlinkLeft");
  m.blink_right = one("eyeBlinkRight");
  const char* sides[2] = {"Left", "Right"};
  for (int s = 0; s < 2; ++s) {
    m.look_up[s] = one(std::string("eyeLookUp") + sides[s]);
    m.look_down[s] = one(std::string("eyeLookDown") + sides[s]);
    m.look_in[s] = one(std::string("eyeLookIn") + sides[s]);
    m.look_out[s] = one(std::string("eyeLookOut") + sides[s]);
  }
  return m;
}

const std::vector<std::vector<Mapping::Entry>>& Mapping::visemes(VisemeSet set) const {
  return sets_[set_index(set)];
}
const std::vector<std::string>& Mapping::viseme_names(VisemeSet set) const {
  return set_names_[set_index(set)];
}
const std::vector<Mapping::Entry>* Mapping::expression(const std::string& name) const {
  for (const auto& [n, row] : expressions_)
    if (n == name) return &row;
  return nullptr;
}

// ---------------------------------------------------------------------------------------------
// Performance

Performance::Performance(const viseme::Utterance& u, const Mapping& mapping,
                         const AnimOptions& options)
    : mapping_(mapping), set_(u.set), options_(options) {
  const auto& names = mapping_.viseme_names(set_);
  const int channels = static_cast<int>(names.size());
  std::map<std::string, int, std::less<>> channel_of;
  for (int c = 0; c < channels; ++c) channel_of[names[c]] = c;

  const std::string closure_key = set_ == VisemeSet::kZh15 ? "zh15" : "oculus";
  for (const char* v : set_ == VisemeSet::kZh15    ? std::vector<const char*>{"bpm", "f"}
                       : set_ == VisemeSet::kMpeg4 ? std::vector<const char*>{"pbm", "fv"}
                                                   : std::vector<const char*>{"PP", "FF"})
    if (const auto it = channel_of.find(v); it != channel_of.end())
      closure_channels_.push_back(it->second);

  // 1. Events with channel, centre and dominance strength. "sil"/"none" events are rest (-1).
  struct Ev {
    int channel;
    double start, end, centre, alpha;
  };
  std::vector<Ev> events;
  double last_end = 0;
  for (const auto& e : u.visemes) {
    const auto it = channel_of.find(e.viseme);
    if (it == channel_of.end())
      throw Error("viseme '" + e.viseme + "' at " + std::to_string(e.start) +
                  " s is not in the utterance's set " + std::string(viseme::to_string(set_)));
    const bool rest = it->second == 0;
    const bool closure = std::find(closure_channels_.begin(), closure_channels_.end(),
                                   it->second) != closure_channels_.end();
    events.push_back({rest ? -1 : it->second, e.start, e.end, 0.5 * (e.start + e.end),
                      rest      ? 0.5
                      : closure ? options_.closure_alpha
                                : 1.0});
    last_end = std::max(last_end, e.end);
  }
  speech_duration_ = std::max(u.duration, last_end);
  duration_ = speech_duration_ + options_.tail;

  const auto rest_key = [&](double t) { keys_.push_back({t, std::vector<float>(channels, 0.0f)}); };
  const auto dominance_key = [&](double t, int own) {
    std::vector<double> acc(channels, 0.0);
    double total = 0;
    for (const auto& e : events) {
      const double dt = t - e.centre;
      // Only neighbours within a few decay lengths matter; skip the rest.
      const double theta = dt < 0 ? options_.theta_anticipation : options_.theta_carryover;
      if (std::abs(dt) * theta > 8) continue;
      const double d = e.alpha * std::exp(-theta * std::abs(dt));
      total += d;
      if (e.channel >= 0) acc[e.channel] += d;
    }
    std::vector<float> value(channels, 0.0f);
    for (int c = 0; c < channels; ++c)
      value[c] = static_cast<float>(options_.articulation * acc[c] / std::max(total, 1e-12));
    // Closure visemes reach full closure: the lips meet whatever the neighbours are.
    if (std::find(closure_channels_.begin(), closure_channels_.end(), own) !=
        closure_channels_.end()) {
      const float scale = 1.0f - value[own];
      for (int c = 0; c < channels; ++c) value[c] = c == own ? 1.0f : value[c] * scale;
    }
    keys_.push_back({t, std::move(value)});
  };

  // 2. Keys: rest before the first and after the last sound, rest plateaus in long pauses, and
  // one dominance-blended key at each sounding viseme's centre.
  bool any = false;
  for (size_t i = 0; i < events.size(); ++i) {
    const auto& e = events[i];
    if (e.channel < 0) {
      if (e.end - e.start >= options_.rest_pause) {
        rest_key(e.start + options_.rest_ramp);
        rest_key(std::max(e.start + options_.rest_ramp, e.end - options_.rest_ramp));
      }
      continue;
    }
    if (!any) rest_key(e.start - options_.rest_ramp);
    any = true;
    dominance_key(e.centre, e.channel);
  }
  if (any) {
    double end = 0;
    for (const auto& e : events)
      if (e.channel >= 0) end = std::max(end, e.end);
    rest_key(end + options_.rest_ramp);
  }
  std::stable_sort(keys_.begin(), keys_.end(), [](auto& a, auto& b) { return a.t < b.t; });
  // Rest plateaus inside a pause come out in order already; drop keys that share a time.
  keys_.erase(std::unique(keys_.begin(), keys_.end(),
                          [](auto& a, auto& b) { return std::abs(a.t - b.t) < 1e-6; }),
              keys_.end());

  // 3. Expressions: per name, Hermite ramps with the seed's three start cases, then a release to
  // rest over the tail after the speech.
  std::vector<viseme::ExpressionEvent> tags = u.expressions;
  std::stable_sort(tags.begin(), tags.end(), [](auto& a, auto& b) { return a.start < b.start; });
  for (const auto& tag : tags) {
    const auto* row = mapping_.expression(tag.name);
    auto it = std::find_if(expressions_.begin(), expressions_.end(),
                           [&](auto& c) { return c.name == tag.name; });
    if (it == expressions_.end()) {
      expressions_.push_back({tag.name, row ? *row : std::vector<Mapping::Entry>{}, {}});
      it = expressions_.end() - 1;
    }
    const float target = std::clamp(tag.intensity / 63.0f, 0.0f, 1.0f);
    const double T = std::max(tag.ramp, 0.0);
    ExprSegment s{tag.start, T, 0.0f, target, 0.0f};
    if (!it->segments.empty()) {
      const auto& p = it->segments.back();
      if (tag.start >= p.t0 + p.T) {  // the previous one finished: start from its target
        s.v0 = p.v1;
      } else {  // interrupted: its current value and tangent (rescaled to this ramp's length)
        const double up = p.T > 0 ? (tag.start - p.t0) / p.T : 1.0;
        s.v0 = hermite(p.v0, p.v1, p.g, up);
        s.g = p.T > 0 ? static_cast<float>(hermite_slope(p.v0, p.v1, p.g, up) / p.T * T) : 0.0f;
      }
    }
    it->segments.push_back(s);
  }
  for (auto& c : expressions_) {
    const auto& p = c.segments.back();
    const double t0 = std::max(speech_duration_, p.t0);
    const double up = p.T > 0 ? std::min(1.0, (t0 - p.t0) / p.T) : 1.0;
    const float v0 = hermite(p.v0, p.v1, p.g, up);
    const float g =
        up < 1 ? static_cast<float>(hermite_slope(p.v0, p.v1, p.g, up) / p.T * options_.tail)
               : 0.0f;
    if (v0 != 0 || g != 0) c.segments.push_back({t0, options_.tail, v0, 0.0f, g});
  }

  // 4. Idle life: blink times, saccade targets, head-motion phases.
  if (options_.idle) {
    Rng rng{options_.seed * 0x2545F4914F6CDD1Dull + 7};
    for (double t = rng.uniform(0.4, options_.blink_interval_max); t < duration_;
         t += rng.uniform(options_.blink_interval_min, options_.blink_interval_max))
      blinks_.push_back(t);
    gazes_.push_back({0.0, {0.0f, 0.0f}});
    for (double t = rng.uniform(0.5, 1.5); t < duration_ - 0.3; t += rng.uniform(0.7, 2.2)) {
      const auto x = static_cast<float>(rng.uniform(-1, 1)),
                 y = static_cast<float>(rng.uniform(-0.6, 0.6));
      gazes_.push_back({t, {x, y}});
    }
    gazes_.push_back({std::max(0.0, duration_ - 0.3), {0.0f, 0.0f}});
    for (double& p : head_phase_) p = rng.uniform(0, 2 * M_PI);
  }
}

int Performance::frame_count(double fps) const {
  if (!(fps > 0)) throw Error("fps must be positive");
  return static_cast<int>(std::ceil(duration_ * fps - 1e-9));
}

std::vector<float> Performance::viseme_channels(double t) const {
  const size_t channels = mapping_.viseme_names(set_).size();
  if (keys_.empty()) return std::vector<float>(channels, 0.0f);
  const auto hi = std::upper_bound(keys_.begin(), keys_.end(), t,
                                   [](double v, const Key& k) { return v < k.t; });
  if (hi == keys_.begin()) return keys_.front().value;
  if (hi == keys_.end()) return keys_.back().value;
  const auto& a = *(hi - 1);
  const auto& b = *hi;
  const double u = (t - a.t) / (b.t - a.t);
  std::vector<float> out(channels);
  for (size_t c = 0; c < channels; ++c) out[c] = hermite(a.value[c], b.value[c], 0.0f, u);
  return out;
}

float Performance::expression_value(const std::string& name, double t) const {
  for (const auto& c : expressions_) {
    if (c.name != name) continue;
    const auto it = std::upper_bound(c.segments.begin(), c.segments.end(), t,
                                     [](double v, const ExprSegment& s) { return v < s.t0; });
    if (it == c.segments.begin()) return 0.0f;
    const auto& s = *(it - 1);
    if (s.T <= 0 || t >= s.t0 + s.T) return s.v1;
    return std::clamp(hermite(s.v0, s.v1, s.g, (t - s.t0) / s.T), 0.0f, 1.0f);
  }
  return 0.0f;
}

void Performance::sample(double t, std::span<float> weights, HeadPose* head) const {
  const auto& shapes = mapping_.shape_names();
  if (weights.size() != shapes.size())
    throw Error("sample: " + std::to_string(weights.size()) + " weights for a rig with " +
                std::to_string(shapes.size()) + " shapes");
  std::fill(weights.begin(), weights.end(), 0.0f);

  // Visemes: a convex blend of viseme poses (channels from the key curve).
  const std::vector<float> ch = viseme_channels(t);
  const auto& rows = mapping_.visemes(set_);
  float closure = 0;
  for (const int c : closure_channels_) closure += ch[c];
  closure = std::clamp(closure, 0.0f, 1.0f);
  for (size_t c = 0; c < ch.size(); ++c)
    if (ch[c] != 0)
      for (const auto& e : rows[c]) weights[e.shape] += ch[c] * e.weight;

  // Expressions, summed, then mixed by the max rule; closure damps the mouth-opening shapes.
  if (!expressions_.empty()) {
    thread_local std::vector<float> expr;
    expr.assign(shapes.size(), 0.0f);
    for (const auto& c : expressions_) {
      const float v = expression_value(c.name, t);
      if (v != 0)
        for (const auto& e : c.entries) expr[e.shape] += v * e.weight;
    }
    // Only a closure on its way to full contact damps (coarticulated traces of a /p/ do not).
    const auto keep = static_cast<float>(1 - smooth((closure - 0.2) / 0.7));
    for (const int s : mapping_.closure_damped()) expr[s] *= keep;
    for (size_t s = 0; s < shapes.size(); ++s) weights[s] = std::max(weights[s], expr[s]);
  }

  if (head) *head = {};
  if (options_.idle) {
    // Blinks: close, hold, open, by the max rule with whatever else drives the lids.
    float blink = 0;
    for (const double b : blinks_) {
      const double dt = t - b;
      if (dt < -options_.blink_close) break;
      if (dt < 0)
        blink = std::max(blink, static_cast<float>(smooth(1 + dt / options_.blink_close)));
      else if (dt < options_.blink_hold)
        blink = 1;
      else if (dt < options_.blink_hold + options_.blink_open)
        blink = std::max(blink, static_cast<float>(
                                    1 - smooth((dt - options_.blink_hold) / options_.blink_open)));
    }
    for (const int s : {mapping_.blink_left, mapping_.blink_right})
      if (s >= 0) weights[s] = std::max(weights[s], blink);

    // Saccades: a quick Hermite move (40 ms) to each new gaze target.
    auto g = std::upper_bound(gazes_.begin(), gazes_.end(), t,
                              [](double v, const auto& p) { return v < p.first; });
    float gx = 0, gy = 0;
    if (g != gazes_.begin()) {
      const auto& cur = *(g - 1);
      const auto& prev = g - 1 == gazes_.begin() ? cur : *(g - 2);
      const double u = smooth((t - cur.first) / 0.04);
      gx = static_cast<float>(prev.second[0] + (cur.second[0] - prev.second[0]) * u);
      gy = static_cast<float>(prev.second[1] + (cur.second[1] - prev.second[1]) * u);
    }
    const auto amp = static_cast<float>(options_.eye_motion);
    // +x looks to the subject's left: the left eye out, the right eye in.
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

    if (head) {
      // Slow sums of sines, faded in and out over 0.5 s so consecutive utterances join at rest.
      const double env = smooth(t / 0.5) * smooth((duration_ - t) / 0.5);
      const double a = options_.head_motion * env;
      head->yaw = static_cast<float>(a * (0.6 * std::sin(2 * M_PI * 0.13 * t + head_phase_[0]) +
                                          0.4 * std::sin(2 * M_PI * 0.31 * t + head_phase_[1])));
      head->pitch = static_cast<float>(a * 0.7 *
                                       (0.7 * std::sin(2 * M_PI * 0.17 * t + head_phase_[1]) +
                                        0.3 * std::sin(2 * M_PI * 0.43 * t + head_phase_[2])));
      head->roll = static_cast<float>(a * 0.4 * std::sin(2 * M_PI * 0.11 * t + head_phase_[2]));
    }
  }
  for (float& w : weights) w = std::clamp(w, 0.0f, 1.0f);
}

// ---------------------------------------------------------------------------------------------

WeightTrack bake(const Performance& performance, double fps, double until) {
  WeightTrack track;
  track.shapes = performance.shape_names();
  track.fps = fps;
  track.frames =
      until > 0 ? static_cast<int>(std::ceil(until * fps - 1e-9)) : performance.frame_count(fps);
  track.weights.resize(static_cast<size_t>(track.frames) * track.shapes.size());
  track.head.resize(track.frames);
  for (int f = 0; f < track.frames; ++f)
    performance.sample(
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
  for (int f = 0; f < track.frames; ++f) {
    const auto row = track.frame(f);
    nlohmann::json r = nlohmann::json::array();
    for (const float v : row) r.push_back(std::round(v * 1e5f) / 1e5f);
    w.push_back(std::move(r));
    const auto& p = track.head[f];
    h.push_back({p.yaw, p.pitch, p.roll});
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
