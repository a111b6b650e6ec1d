// Steps 1-4 of the animation chain. See animation_steps.hpp.
#include "facecast/anim/animation_steps.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "facecast/anim/animation.hpp"
#include "facecast/core/error.hpp"

namespace facecast::anim {
namespace {

double smooth(double u) {
  return u <= 0 ? 0 : u >= 1 ? 1 : u * u * (3 - 2 * u);
}

bool contains(const std::vector<int>& list, int value) {
  return std::find(list.begin(), list.end(), value) != list.end();
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

}  // namespace

float hermite(float a0, float a1, float g, double u) {
  const double u2 = u * u, u3 = u2 * u;
  return static_cast<float>((2 * u3 - 3 * u2 + 1) * a0 + (-2 * u3 + 3 * u2) * a1 +
                            (u3 - 2 * u2 + u) * g);
}

float hermite_slope(float a0, float a1, float g, double u) {
  const double u2 = u * u;
  return static_cast<float>((6 * u2 - 6 * u) * a0 + (-6 * u2 + 6 * u) * a1 +
                            (3 * u2 - 4 * u + 1) * g);
}

// ---- 1. Visemes -> keys ------------------------------------------------------------------------

std::vector<DominanceEvent> dominance_events(const std::vector<viseme::VisemeEvent>& visemes,
                                             const std::vector<std::string>& names,
                                             const std::vector<int>& closure, double closure_alpha,
                                             viseme::VisemeSet set) {
  std::map<std::string, int, std::less<>> channel_of;
  for (int c = 0; c < static_cast<int>(names.size()); ++c) channel_of[names[c]] = c;
  std::vector<DominanceEvent> events;
  for (const auto& e : visemes) {
    const auto it = channel_of.find(e.viseme);
    if (it == channel_of.end())
      throw Error("viseme '" + e.viseme + "' at " + std::to_string(e.start) +
                  " s is not in the utterance's set " + std::string(viseme::to_string(set)));
    const bool rest = it->second == 0;
    events.push_back({rest ? -1 : it->second, e.start, e.end, 0.5 * (e.start + e.end),
                      rest                            ? 0.5
                      : contains(closure, it->second) ? closure_alpha
                                                      : 1.0,
                      e.strength});
  }
  return events;
}

std::vector<float> dominance_blend(std::span<const DominanceEvent> events, int channels,
                                   const std::vector<int>& closure, const AnimOptions& options,
                                   double t, int own) {
  std::vector<double> acc(channels, 0.0);
  double total = 0;
  for (const auto& e : events) {
    const double dt = t - e.centre;
    // Only neighbours within a few decay lengths matter; skip the rest.
    const double theta = dt < 0 ? options.theta_anticipation : options.theta_carryover;
    if (std::abs(dt) * theta > 8) continue;
    const double d = e.alpha * std::exp(-theta * std::abs(dt));
    total += d;
    if (e.channel >= 0) acc[e.channel] += d * e.strength;
  }
  std::vector<float> value(channels, 0.0f);
  for (int c = 0; c < channels; ++c)
    value[c] = static_cast<float>(options.articulation * acc[c] / std::max(total, 1e-12));
  // Closure visemes reach full closure: the lips meet whatever the neighbours are.
  if (contains(closure, own)) {
    const float scale = 1.0f - value[own];
    for (int c = 0; c < channels; ++c) value[c] = c == own ? 1.0f : value[c] * scale;
  }
  return value;
}

std::vector<ChannelKey> viseme_keys(std::span<const DominanceEvent> events, int channels,
                                    const std::vector<int>& closure, const AnimOptions& options) {
  std::vector<ChannelKey> keys;
  const auto rest_key = [&](double t) { keys.push_back({t, std::vector<float>(channels, 0.0f)}); };
  bool any = false;
  for (const auto& e : events) {
    if (e.channel < 0) {
      if (e.end - e.start >= options.rest_pause) {
        rest_key(e.start + options.rest_ramp);
        rest_key(std::max(e.start + options.rest_ramp, e.end - options.rest_ramp));
      }
      continue;
    }
    if (!any) rest_key(e.start - options.rest_ramp);
    any = true;
    keys.push_back(
        {e.centre, dominance_blend(events, channels, closure, options, e.centre, e.channel)});
  }
  if (any) {
    double end = 0;
    for (const auto& e : events)
      if (e.channel >= 0) end = std::max(end, e.end);
    rest_key(end + options.rest_ramp);
  }
  std::stable_sort(keys.begin(), keys.end(), [](auto& a, auto& b) { return a.t < b.t; });
  // Rest plateaus inside a pause come out in order already; drop keys that share a time.
  keys.erase(std::unique(keys.begin(), keys.end(),
                         [](auto& a, auto& b) { return std::abs(a.t - b.t) < 1e-6; }),
             keys.end());
  return keys;
}

// ---- 2. Between keys ---------------------------------------------------------------------------

std::vector<float> sample_keys(const std::vector<ChannelKey>& keys, std::size_t channels,
                               double t) {
  if (keys.empty()) return std::vector<float>(channels, 0.0f);
  const auto hi = std::upper_bound(keys.begin(), keys.end(), t,
                                   [](double v, const ChannelKey& k) { return v < k.t; });
  if (hi == keys.begin()) return keys.front().value;
  if (hi == keys.end()) return keys.back().value;
  const auto& a = *(hi - 1);
  const auto& b = *hi;
  const double u = (t - a.t) / (b.t - a.t);
  std::vector<float> out(channels);
  for (std::size_t c = 0; c < channels; ++c) out[c] = hermite(a.value[c], b.value[c], 0.0f, u);
  return out;
}

// ---- 3. Expressions ----------------------------------------------------------------------------

ExpressionSegment next_ramp(const ExpressionSegment* previous, double start, double T,
                            float target) {
  ExpressionSegment s{start, T, 0.0f, target, 0.0f};
  if (!previous) return s;  // the first: from 0
  const auto& p = *previous;
  if (start >= p.t0 + p.T) {  // the previous one finished: start from its target
    s.v0 = p.v1;
  } else {  // interrupted: its current value and tangent (rescaled to this ramp's length)
    const double up = p.T > 0 ? (start - p.t0) / p.T : 1.0;
    s.v0 = hermite(p.v0, p.v1, p.g, up);
    s.g = p.T > 0 ? static_cast<float>(hermite_slope(p.v0, p.v1, p.g, up) / p.T * T) : 0.0f;
  }
  return s;
}

std::vector<ExpressionCurve> expression_curves(const std::vector<viseme::ExpressionEvent>& tags,
                                               double release_at, double tail) {
  std::vector<viseme::ExpressionEvent> sorted = tags;
  std::stable_sort(sorted.begin(), sorted.end(),
                   [](auto& a, auto& b) { return a.start < b.start; });
  std::vector<ExpressionCurve> curves;
  for (const auto& tag : sorted) {
    auto it =
        std::find_if(curves.begin(), curves.end(), [&](auto& c) { return c.name == tag.name; });
    if (it == curves.end()) {
      curves.push_back({tag.name, {}});
      it = curves.end() - 1;
    }
    const float target = std::clamp(tag.intensity / 63.0f, 0.0f, 1.0f);
    const double T = std::max(tag.ramp, 0.0);
    it->segments.push_back(
        next_ramp(it->segments.empty() ? nullptr : &it->segments.back(), tag.start, T, target));
  }
  // The release: from wherever the last ramp is at release_at, to 0 over the tail.
  for (auto& c : curves) {
    const auto& p = c.segments.back();
    const double t0 = std::max(release_at, p.t0);
    const double up = p.T > 0 ? std::min(1.0, (t0 - p.t0) / p.T) : 1.0;
    const float v0 = hermite(p.v0, p.v1, p.g, up);
    const float g =
        up < 1 ? static_cast<float>(hermite_slope(p.v0, p.v1, p.g, up) / p.T * tail) : 0.0f;
    if (v0 != 0 || g != 0) c.segments.push_back({t0, tail, v0, 0.0f, g});
  }
  return curves;
}

float sample_curve(const ExpressionCurve& curve, double t) {
  const auto it = std::upper_bound(curve.segments.begin(), curve.segments.end(), t,
                                   [](double v, const ExpressionSegment& s) { return v < s.t0; });
  if (it == curve.segments.begin()) return 0.0f;
  const auto& s = *(it - 1);
  if (s.T <= 0 || t >= s.t0 + s.T) return s.v1;
  return std::clamp(hermite(s.v0, s.v1, s.g, (t - s.t0) / s.T), 0.0f, 1.0f);
}

// ---- 4. Idle life ------------------------------------------------------------------------------

std::vector<Span> speech_spans(const viseme::Utterance& u, double pause) {
  struct Piece {
    double start, end;
  };
  std::vector<Piece> pieces;
  for (const auto& w : u.words) pieces.push_back({w.start, w.end});
  if (pieces.empty())
    for (const auto& v : u.visemes)
      if (v.viseme != "sil") pieces.push_back({v.start, v.end});
  std::sort(pieces.begin(), pieces.end(),
            [](const Piece& a, const Piece& b) { return a.start < b.start; });
  std::vector<Span> spans;
  std::size_t first = 0;                      // of the current span's pieces
  const auto close = [&](std::size_t last) {  // pieces [first, last)
    Span s{pieces[first].start, pieces[first].end, -1};
    double total = 0, longest = 0, longest_at = -1;
    for (std::size_t i = first; i < last; ++i) {
      s.end = std::max(s.end, pieces[i].end);
      const double len = pieces[i].end - pieces[i].start;
      total += len;
      if (len > longest) longest = len, longest_at = pieces[i].start;
    }
    const double mean = total / static_cast<double>(last - first);
    if (!u.words.empty() && last - first >= 3 && longest > 1.4 * mean && longest_at > s.start + 0.3)
      s.accent = longest_at;
    spans.push_back(s);
  };
  double end = pieces.empty() ? 0 : pieces[0].end;  // of the current span so far
  for (std::size_t i = 1; i <= pieces.size(); ++i) {
    if (i == pieces.size() || pieces[i].start - end >= pause) {
      close(i);
      first = i;
    }
    if (i < pieces.size()) end = first == i ? pieces[i].end : std::max(end, pieces[i].end);
  }
  return spans;
}

IdleLife idle_life(double duration, const std::vector<Span>& phrases, const AnimOptions& options) {
  IdleLife idle;
  idle.duration = duration;
  idle.phrases = phrases;
  float side = 1;
  for (const Span& p : phrases) {
    idle.nods.push_back({p.start, 1.0f, 0.4f * side});
    if (p.accent >= 0) idle.nods.push_back({p.accent, 0.6f, -0.4f * side});
    side = -side;
  }
  Rng rng{options.seed * 0x2545F4914F6CDD1Dull + 7};
  for (double t = rng.uniform(0.4, options.blink_interval_max); t < duration;
       t += rng.uniform(options.blink_interval_min, options.blink_interval_max))
    idle.blinks.push_back(t);
  idle.gazes.push_back({0.0, {0.0f, 0.0f}});
  for (double t = rng.uniform(0.5, 1.5); t < duration - 0.3; t += rng.uniform(0.7, 2.2)) {
    const auto x = static_cast<float>(rng.uniform(-1, 1)),
               y = static_cast<float>(rng.uniform(-0.6, 0.6));
    idle.gazes.push_back({t, {x, y}});
  }
  idle.gazes.push_back({std::max(0.0, duration - 0.3), {0.0f, 0.0f}});
  for (double& p : idle.head_phase) p = rng.uniform(0, 2 * M_PI);
  for (double& p : idle.body_phase) p = rng.uniform(0, 2 * M_PI);
  return idle;
}

float blink_at(const IdleLife& idle, const AnimOptions& options, double t) {
  float blink = 0;
  for (const double b : idle.blinks) {
    const double dt = t - b;
    if (dt < -options.blink_close) break;
    if (dt < 0)
      blink = std::max(blink, static_cast<float>(smooth(1 + dt / options.blink_close)));
    else if (dt < options.blink_hold)
      blink = 1;
    else if (dt < options.blink_hold + options.blink_open)
      blink = std::max(
          blink, static_cast<float>(1 - smooth((dt - options.blink_hold) / options.blink_open)));
  }
  return blink;
}

std::array<float, 2> gaze_at(const IdleLife& idle, double t) {
  const auto g = std::upper_bound(idle.gazes.begin(), idle.gazes.end(), t,
                                  [](double v, const auto& p) { return v < p.first; });
  if (g == idle.gazes.begin()) return {0.0f, 0.0f};
  const auto& cur = *(g - 1);
  const auto& prev = g - 1 == idle.gazes.begin() ? cur : *(g - 2);
  const double u = smooth((t - cur.first) / 0.04);
  return {static_cast<float>(prev.second[0] + (cur.second[0] - prev.second[0]) * u),
          static_cast<float>(prev.second[1] + (cur.second[1] - prev.second[1]) * u)};
}

rig::BodyPose head_at(const IdleLife& idle, const AnimOptions& options, double t) {
  // Slow sums of sines, faded in and out over 0.5 s so consecutive utterances join at rest, at
  // full amplitude while a phrase lasts (ramping over 0.4 s), half of it in pauses.
  const auto& phase = idle.head_phase;
  const double env = smooth(t / 0.5) * smooth((idle.duration - t) / 0.5);
  double speaking = idle.phrases.empty() ? 1.0 : 0.0;
  for (const Span& p : idle.phrases)
    speaking =
        std::max(speaking, smooth((t - p.start + 0.2) / 0.4) * smooth((p.end - t + 0.2) / 0.4));
  const double a = options.head_motion * env * (0.5 + 0.5 * speaking);
  rig::BodyPose head;
  head.yaw = static_cast<float>(a * (0.6 * std::sin(2 * M_PI * 0.13 * t + phase[0]) +
                                     0.4 * std::sin(2 * M_PI * 0.31 * t + phase[1])));
  head.pitch = static_cast<float>(a * 0.7 *
                                  (0.7 * std::sin(2 * M_PI * 0.17 * t + phase[1]) +
                                   0.3 * std::sin(2 * M_PI * 0.43 * t + phase[2])));
  head.roll = static_cast<float>(a * 0.4 * std::sin(2 * M_PI * 0.11 * t + phase[2]));
  // Nods: pitch down and back, sin^2 over 0.45 s starting 0.05 s before the onset.
  for (const Nod& n : idle.nods) {
    const double u = (t - n.t + 0.05) / 0.45;
    if (u <= 0 || u >= 1) continue;
    const double bump = std::sin(M_PI * u) * std::sin(M_PI * u) * env;
    head.pitch += static_cast<float>(options.head_nod * n.strength * bump);
    head.roll += static_cast<float>(options.head_nod * n.tilt * bump);
  }
  return head;
}

float breath_at(const IdleLife& idle, const AnimOptions& options, double t) {
  constexpr double kInhale = 0.45, kExhaleRate = 0.15, kFloor = 0.2, kBackToRest = 1.0;
  const auto& phrases = idle.phrases;
  const auto rest = [&](double u) {
    return 0.5 - 0.5 * std::cos(2 * M_PI * options.breath_rate * u + idle.body_phase[0]);
  };
  // A phrase's breath in starts 0.45 s before it, or in the pause before it when that is shorter.
  const auto inhale_at = [&](std::size_t p) {
    const double gap = p == 0 ? kInhale : phrases[p].start - phrases[p - 1].end;
    return phrases[p].start - std::min(kInhale, gap);
  };
  // The breath from phrase p's inhale on, from `from_level` (its end level is held after it).
  const auto through = [&](std::size_t p, double from_level, double u) {
    const Span& s = phrases[p];
    if (u < s.start) {
      const double len = s.start - inhale_at(p);
      return from_level + (1 - from_level) * smooth((u - inhale_at(p)) / std::max(len, 1e-3));
    }
    return std::max(kFloor, 1 - kExhaleRate * (std::min(u, s.end) - s.start));
  };
  double level = 0;  // when the current phrase's inhale starts
  std::size_t p = 0;
  for (; p < phrases.size() && inhale_at(p) <= t; ++p)
    level = p == 0 ? rest(inhale_at(0)) : through(p - 1, level, inhale_at(p));
  double b = p == 0 ? rest(t) : through(p - 1, level, t);
  if (p > 0 && p == phrases.size())  // after the last phrase, back to the resting cycle
    b += (rest(t) - b) * smooth((t - phrases.back().end) / kBackToRest);
  const double env = smooth(t / 0.5) * smooth((idle.duration - t) / 0.5);
  return static_cast<float>(options.breath_depth * env * std::clamp(b, 0.0, 1.0));
}

rig::BodyPose body_at(const IdleLife& idle, const AnimOptions& options, double t) {
  rig::BodyPose pose = head_at(idle, options, t);
  const double env = smooth(t / 0.5) * smooth((idle.duration - t) / 0.5);
  pose.breath = breath_at(idle, options, t);
  pose.lean = static_cast<float>(options.body_lean * env *
                                 (0.7 * std::sin(2 * M_PI * 0.07 * t + idle.body_phase[1]) +
                                  0.3 * std::sin(2 * M_PI * 0.19 * t + idle.head_phase[0])));
  double shrug = 0;
  for (const Nod& n : idle.nods) {
    if (n.strength >= 1) continue;  // phrase starts nod; accents also shrug
    const double u = (t - n.t + 0.05) / 0.6;
    if (u > 0 && u < 1) shrug = std::max(shrug, std::sin(M_PI * u) * std::sin(M_PI * u));
  }
  pose.shrug = static_cast<float>(options.shrug * env * shrug);
  return pose;
}

// ---- 5. Mixing ---------------------------------------------------------------------------------

float closure_keep(float closure) {
  return static_cast<float>(1 - smooth((closure - 0.2) / 0.7));
}

}  // namespace facecast::anim
