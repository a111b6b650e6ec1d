// Tracks and mixing: coarticulation, closure, expression ramps, rest, idle life, mappings.
#include <catch2/catch.hpp>
#include <cmath>

#include "facecast/anim/animation.hpp"
#include "facecast/avatar/avatar.hpp"
#include "facecast/core/error.hpp"
#include "facecast/viseme/analyze.hpp"

using namespace facecast;
using namespace facecast::anim;
using namespace facecast::rig;

namespace {

const Rig& face() {
  static const Rig rig = avatar::default_avatar();
  return rig;
}

AnimOptions quiet() {
  AnimOptions o;
  o.idle = false;
  return o;
}

float weight(const Performance& p, const std::string& shape, double t) {
  std::vector<float> w(p.shape_names().size());
  p.sample(t, w);
  const auto& n = p.shape_names();
  return w[std::find(n.begin(), n.end(), shape) - n.begin()];
}

viseme::Utterance zh(const std::string& text) {
  viseme::Options o;
  o.timing = viseme::Timing::kModel;
  return viseme::analyze(text, o);
}

int channel(const Mapping& m, viseme::VisemeSet set, const std::string& name) {
  const auto& n = m.viseme_names(set);
  return static_cast<int>(std::find(n.begin(), n.end(), name) - n.begin());
}

}  // namespace

TEST_CASE("the options file mirrors AnimOptions", "[anim][animation]") {
  const AnimOptions file = load_anim_options(), code;
  CHECK(file.theta_anticipation == code.theta_anticipation);
  CHECK(file.theta_carryover == code.theta_carryover);
  CHECK(file.closure_alpha == code.closure_alpha);
  CHECK(file.rest_pause == code.rest_pause);
  CHECK(file.tail == code.tail);
  CHECK(file.idle == code.idle);
  CHECK(file.blink_interval_max == code.blink_interval_max);
  CHECK(file.head_motion == code.head_motion);
  CHECK(file.head_nod == code.head_nod);
  CHECK(file.seed == code.seed);
}

TEST_CASE("mappings resolve ARKit, ICT _L/_R and Oculus names", "[anim][animation]") {
  const Mapping arkit = Mapping::for_rig(face().shape_names());
  CHECK(arkit.table() == "arkit");
  CHECK(arkit.blink_left >= 0);
  const auto& a_row =
      arkit.visemes(viseme::VisemeSet::kZh15)[channel(arkit, viseme::VisemeSet::kZh15, "a")];
  REQUIRE(!a_row.empty());

  // The ICT FaceKit names: Left/Right -> _L/_R; unsided browInnerUp is split over _L and _R.
  const std::vector<std::string> ict = {"jawOpen",       "mouthLowerDown_L", "mouthLowerDown_R",
                                        "browInnerUp_L", "browInnerUp_R",    "eyeBlink_L",
                                        "eyeBlink_R",    "mouthPress_L",     "mouthPress_R",
                                        "mouthSmile_L",  "mouthSmile_R"};
  const Mapping m = Mapping::for_rig(ict);
  CHECK(m.blink_left == 5);
  CHECK(m.blink_right == 6);
  const auto* surprise = m.expression("surprise");
  REQUIRE(surprise != nullptr);
  int brows = 0;
  for (const auto& e : *surprise) brows += e.shape == 3 || e.shape == 4;
  CHECK(brows == 2);
  const auto& bpm =
      m.visemes(viseme::VisemeSet::kZh15)[channel(m, viseme::VisemeSet::kZh15, "bpm")];
  CHECK(bpm.size() == 2);  // mouthPress_L and _R

  std::vector<std::string> oculus;
  for (const char* v :
       {"sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS", "nn", "RR", "aa", "E", "I", "O", "U"})
    oculus.push_back(std::string("viseme_") + v);
  const Mapping o = Mapping::for_rig(oculus);
  CHECK(o.table() == "oculus");
  const auto& pp =
      o.visemes(viseme::VisemeSet::kMpeg4)[channel(o, viseme::VisemeSet::kMpeg4, "pbm")];
  REQUIRE(pp.size() == 1);
  CHECK(oculus[pp[0].shape] == "viseme_PP");

  CHECK_THROWS_AS(Mapping::for_rig({"leftArmRaise", "rightArmRaise"}), Error);
}

TEST_CASE("bilabials and labiodentals reach closure", "[anim][animation]") {
  const Mapping m = Mapping::for_rig(face().shape_names());
  // A smiling, surprised speaker: expressions drive jawOpen and smiles, closure must still win.
  const auto u = zh("(surprise, 63, 0.2)(joy, 63, 0.2)爸爸买了很多面包，妈妈非常高兴。");
  const Performance p(u, m, quiet());
  int checked = 0;
  for (const auto& v : u.visemes) {
    if (v.viseme != "bpm" && v.viseme != "f") continue;
    const double t = 0.5 * (v.start + v.end);
    const auto ch = p.viseme_channels(t);
    INFO(v.viseme << " at " << t);
    CHECK(ch[channel(m, u.set, v.viseme)] >= 0.99f);
    if (t > 0.3) {  // once the expressions are at full intensity
      CHECK(weight(p, "jawOpen", t) <= 0.05f);
      CHECK(weight(p, "mouthSmileLeft", t) <= 0.05f);
    }
    ++checked;
  }
  CHECK(checked >= 8);
  // Away from closures the surprise keeps the jaw open (the max rule).
  const auto vowel = std::find_if(u.visemes.begin(), u.visemes.end(),
                                  [](auto& v) { return v.start > 0.5 && v.viseme == "a"; });
  REQUIRE(vowel != u.visemes.end());
  CHECK(weight(p, "jawOpen", 0.5 * (vowel->start + vowel->end)) > 0.4f);
}

TEST_CASE("neighbours colour a viseme (coarticulation)", "[anim][animation]") {
  const Mapping m = Mapping::for_rig(face().shape_names());
  // The same /d/ between rounded vowels and between spread ones.
  viseme::Utterance rounded, spread;
  rounded.set = spread.set = viseme::VisemeSet::kZh15;
  // Syllable-length segments: the vowels' centres 75 ms from the /d/'s.
  rounded.visemes = {{"uv", 0.25, 0.35}, {"dtnl", 0.35, 0.4}, {"uv", 0.4, 0.5}};
  spread.visemes = {{"i", 0.25, 0.35}, {"dtnl", 0.35, 0.4}, {"i", 0.4, 0.5}};
  rounded.duration = spread.duration = 0.8;
  const Performance pr(rounded, m, quiet()), ps(spread, m, quiet());
  const double t = 0.375;
  CHECK(weight(pr, "mouthPucker", t) > 0.1f);
  CHECK(weight(ps, "mouthPucker", t) < 0.01f);
  CHECK(weight(ps, "mouthStretchLeft", t) > weight(pr, "mouthStretchLeft", t) + 0.03f);
  // The /d/ itself still dominates its own centre.
  const auto ch = pr.viseme_channels(t);
  CHECK(ch[channel(m, rounded.set, "dtnl")] > 0.5f);
}

TEST_CASE("the face rests in long pauses and after the utterance", "[anim][animation]") {
  const Mapping m = Mapping::for_rig(face().shape_names());
  viseme::Utterance u;
  u.set = viseme::VisemeSet::kOculus;
  u.visemes = {{"sil", 0, 0.2},   {"aa", 0.2, 0.4}, {"PP", 0.4, 0.5},
               {"sil", 0.5, 1.5}, {"O", 1.5, 1.7},  {"sil", 1.7, 1.9}};
  u.duration = 1.9;
  const Performance p(u, m, quiet());
  CHECK(p.duration() == Approx(1.9 + quiet().tail));
  std::vector<float> w(p.shape_names().size()), w2(w.size());
  for (const double t : {0.0, 0.8, 1.0, 1.2, 1.9, 2.19}) {
    p.sample(t, w);
    INFO("t = " << t);
    for (const float v : w) CHECK(v == 0.0f);
  }
  p.sample(0.3, w);
  CHECK(*std::max_element(w.begin(), w.end()) > 0.3f);
  // Continuity: no jumps between frames at 240 fps.
  float worst = 0;
  for (double t = 0; t < p.duration(); t += 1.0 / 240) {
    p.sample(t, w);
    p.sample(t + 1.0 / 240, w2);
    for (size_t s = 0; s < w.size(); ++s) worst = std::max(worst, std::abs(w2[s] - w[s]));
  }
  CHECK(worst < 0.12f);
}

TEST_CASE("expression ramps follow the three start cases", "[anim][animation]") {
  const Mapping m = Mapping::for_rig(face().shape_names());
  viseme::Utterance u;
  u.set = viseme::VisemeSet::kZh15;
  u.duration = 6;
  u.visemes = {{"sil", 0, 6}};
  u.expressions = {
      {"joy", 63, 0.5, 1.0},      // first: from 0, reaches 1.0 at 1.5
      {"joy", 21, 2.0, 1.0},      // previous finished: from 1.0 down to 1/3 by 3.0
      {"joy", 63, 2.5, 1.0},      // interrupts the second halfway: from its value and tangent
      {"sadness", 42, 1.0, 0.0},  // T = 0: a step
  };
  const Performance p(u, m, quiet());
  const auto joy = [&](double t) { return p.expression_value("joy", t); };
  CHECK(joy(0.4) == 0.0f);
  CHECK(joy(1.0) == Approx(0.5).margin(1e-6));  // Hermite midpoint from 0 to 1
  CHECK(joy(1.5) == Approx(1.0));
  CHECK(joy(1.9) == Approx(1.0));
  CHECK(joy(2.5) == Approx(1.0 + (1.0 / 3 - 1.0) * 0.5).margin(1e-5));  // second's midpoint
  // C1 at the interruption: value and slope continue.
  const double h = 1e-4;
  const double before = (joy(2.5 - h) - joy(2.5 - 2 * h)) / h;
  const double after = (joy(2.5 + 2 * h) - joy(2.5 + h)) / h;
  CHECK(after == Approx(before).margin(0.01));
  CHECK(before < -0.5);  // it was still falling
  CHECK(joy(3.5) == Approx(1.0));
  CHECK(p.expression_value("sadness", 0.99) == 0.0f);
  CHECK(p.expression_value("sadness", 1.0) == Approx(42 / 63.0));
  // Released over the tail after the speech.
  CHECK(joy(6.0) == Approx(1.0));
  CHECK(joy(6.0 + quiet().tail) == 0.0f);
  // Expressions reach the rig: joy smiles.
  CHECK(weight(p, "mouthSmileLeft", 3.6) == Approx(0.9).margin(1e-5));
}

TEST_CASE("idle life blinks, moves the eyes and head, and is reproducible", "[anim][animation]") {
  const Mapping m = Mapping::for_rig(face().shape_names());
  viseme::Utterance u;
  u.set = viseme::VisemeSet::kZh15;
  u.duration = 12;
  u.visemes = {{"sil", 0, 12}};
  AnimOptions on;
  const Performance a(u, m, on), b(u, m, on), off(u, m, quiet());
  int blinks = 0;
  float look = 0, head = 0;
  bool closed = false;
  std::vector<float> wa(a.shape_names().size()), wb(wa.size()), wo(wa.size());
  for (double t = 0; t < a.duration(); t += 1.0 / 60) {
    BodyPose ha, hb;
    a.sample(t, wa, &ha);
    b.sample(t, wb, &hb);
    off.sample(t, wo);
    REQUIRE(wa == wb);
    REQUIRE(ha.yaw == hb.yaw);
    for (const float v : wo) REQUIRE(v == 0.0f);
    const float blink = wa[m.blink_left];
    if (blink > 0.95f && !closed) ++blinks;
    closed = blink > 0.95f;
    look =
        std::max({look, wa[m.look_up[0]], wa[m.look_down[0]], wa[m.look_in[0]], wa[m.look_out[0]]});
    head = std::max(head, std::abs(ha.yaw));
  }
  CHECK(blinks >= 2);
  CHECK(blinks <= 7);
  CHECK(look > 0.02f);
  CHECK(look <= on.eye_motion + 1e-6);
  CHECK(head > 0.005f);
  CHECK(head <= on.head_motion);
}

TEST_CASE("bake gives frames at pts f over fps and both output formats", "[anim][animation]") {
  const Mapping m = Mapping::for_rig(face().shape_names());
  const auto u = zh("你好");
  const Performance p(u, m);
  const WeightTrack t = bake(p, 30);
  CHECK(t.frames == static_cast<int>(std::ceil(p.duration() * 30 - 1e-9)));
  CHECK(t.weights.size() == static_cast<size_t>(t.frames) * t.shapes.size());
  std::vector<float> w(t.shapes.size());
  p.sample(7 / 30.0, w);
  CHECK(std::equal(w.begin(), w.end(), t.frame(7).begin()));
  const WeightTrack v = bake(p, 25, p.speech_duration());
  CHECK(v.frames == static_cast<int>(std::ceil(p.speech_duration() * 25 - 1e-9)));
  const std::string bin = to_binary(t);
  CHECK(bin.substr(0, 4) == "FCWT");
  CHECK(bin.size() > t.weights.size() * 4);
  const auto j = nlohmann::json::parse(to_json(t));
  CHECK(j.at("frames") == t.frames);
  CHECK(j.at("weights").size() == static_cast<size_t>(t.frames));
  std::vector<float> three(3);
  CHECK_THROWS_AS(p.sample(0, three), Error);
}

TEST_CASE("fade to rest is smooth and ends at zero", "[anim][animation]") {
  const std::vector<float> from = {1.0f, 0.5f};
  std::vector<float> out(2);
  fade_to_rest(from, 0, 0.2, out);
  CHECK(out == from);
  fade_to_rest(from, 0.1, 0.2, out);
  CHECK(out[0] == Approx(0.5));
  fade_to_rest(from, 0.2, 0.2, out);
  CHECK(out[0] == 0.0f);
}

// ---- The steps of the chain on their own (animation_steps.hpp). ---------------------------------

TEST_CASE("the mapping table names the closure visemes of every set", "[anim][animation]") {
  const Mapping m = Mapping::for_rig(face().shape_names());
  using viseme::VisemeSet;
  CHECK(m.closure_channels(VisemeSet::kZh15) ==
        std::vector<int>{channel(m, VisemeSet::kZh15, "bpm"), channel(m, VisemeSet::kZh15, "f")});
  CHECK(
      m.closure_channels(VisemeSet::kOculus) ==
      std::vector<int>{channel(m, VisemeSet::kOculus, "PP"), channel(m, VisemeSet::kOculus, "FF")});
  CHECK(
      m.closure_channels(VisemeSet::kMpeg4) ==
      std::vector<int>{channel(m, VisemeSet::kMpeg4, "pbm"), channel(m, VisemeSet::kMpeg4, "fv")});
}

TEST_CASE("dominance blends neighbours and closure reaches full value", "[anim][animation]") {
  const AnimOptions o = quiet();
  // Channel 1 at 0.1 s alone, then with a channel-2 neighbour 50 ms later (anticipated).
  std::vector<DominanceEvent> events{{1, 0.05, 0.15, 0.1, 1.0}};
  auto v = dominance_blend(events, 3, {}, o, 0.1, 1);
  CHECK(v == std::vector<float>{0.0f, 1.0f, 0.0f});
  events.push_back({2, 0.1, 0.2, 0.15, 1.0});
  const double d = std::exp(-o.theta_anticipation * 0.05);
  v = dominance_blend(events, 3, {}, o, 0.1, 1);
  CHECK(v[1] == Approx(1 / (1 + d)));
  CHECK(v[2] == Approx(d / (1 + d)));
  // As a closure channel it is pushed to 1 and the neighbour scaled by what it lacked.
  v = dominance_blend(events, 3, {1}, o, 0.1, 1);
  CHECK(v[1] == 1.0f);
  CHECK(v[2] == Approx(d / (1 + d) * (1 - 1 / (1 + d))));
}

TEST_CASE("viseme keys rest around the speech and in long pauses", "[anim][animation]") {
  const AnimOptions o = quiet();
  const std::vector<DominanceEvent> events{{-1, 0.0, 0.2, 0.1, 0.5},
                                           {1, 0.2, 0.4, 0.3, 1.0},
                                           {-1, 0.4, 1.4, 0.9, 0.5},
                                           {2, 1.4, 1.6, 1.5, 1.0}};
  const auto keys = viseme_keys(events, 3, {}, o);
  std::vector<double> times;
  for (const auto& k : keys) times.push_back(k.t);
  const double r = o.rest_ramp;
  REQUIRE(times.size() == 6);
  const std::vector<double> want{0.2 - r, 0.3, 0.4 + r, 1.4 - r, 1.5, 1.6 + r};
  for (size_t i = 0; i < want.size(); ++i) CHECK(times[i] == Approx(want[i]));
  for (const size_t rest : {0, 2, 3, 5}) CHECK(keys[rest].value == std::vector<float>(3, 0.0f));
  // Between keys: the Hermite curve with zero tangents (the midpoint is the mean).
  const auto mid = sample_keys(keys, 3, 0.5 * (times[0] + times[1]));
  CHECK(mid[1] == Approx(0.5 * keys[1].value[1]));
  CHECK(sample_keys({}, 3, 1.0) == std::vector<float>(3, 0.0f));
}

TEST_CASE("the three start cases of an expression ramp", "[anim][animation]") {
  const ExpressionSegment first = next_ramp(nullptr, 1.0, 0.5, 0.8f);
  CHECK(first.v0 == 0.0f);
  CHECK(first.g == 0.0f);
  const ExpressionSegment after = next_ramp(&first, 2.0, 1.0, 0.2f);  // the first has finished
  CHECK(after.v0 == 0.8f);
  CHECK(after.g == 0.0f);
  const ExpressionSegment cut = next_ramp(&after, 2.5, 2.0, 1.0f);  // halfway through `after`
  CHECK(cut.v0 == Approx(0.5f));
  CHECK(cut.g == Approx(hermite_slope(0.8f, 0.2f, 0.0f, 0.5) / 1.0 * 2.0));
  CHECK(cut.g < 0);
}

TEST_CASE("the head nods where phrases start and at their accents, and settles in pauses",
          "[anim][animation]") {
  // Two phrases of words; the second's third word is long (an accent); a 1.2 s pause between.
  viseme::Utterance u;
  u.set = viseme::VisemeSet::kOculus;
  u.words = {{"one", 0.3, 0.6},   {"two", 0.62, 0.9},    {"three", 0.92, 1.2}, {"four", 2.4, 2.6},
             {"five", 2.62, 2.8}, {"siiiix", 2.82, 3.5}, {"seven", 3.52, 3.7}};
  u.visemes = {{"sil", 0, 0.3}, {"aa", 0.3, 1.2}, {"sil", 1.2, 2.4}, {"aa", 2.4, 3.7}};
  u.duration = 4.0;
  const auto spans = speech_spans(u, AnimOptions{}.rest_pause);
  REQUIRE(spans.size() == 2);
  CHECK(spans[0].start == 0.3);
  CHECK(spans[0].end == 1.2);
  CHECK(spans[0].accent == -1);
  CHECK(spans[1].accent == 2.82);

  const Mapping m = Mapping::for_rig(face().shape_names());
  AnimOptions still;
  still.head_motion = 0;  // the nods alone
  const Performance p(u, m, still);
  std::vector<float> w(p.shape_names().size());
  const auto pitch = [&](double t) {
    BodyPose h;
    p.sample(t, w, &h);
    return h.pitch;
  };
  const auto roll = [&](double t) {
    BodyPose h;
    p.sample(t, w, &h);
    return h.roll;
  };
  // Peaks 0.175 s after each onset; the accent's is 60 % and tilts to the other side.
  CHECK(pitch(0.3 + 0.175) == Approx(still.head_nod).epsilon(0.05));
  CHECK(pitch(2.4 + 0.175) == Approx(still.head_nod).epsilon(0.05));
  CHECK(pitch(2.82 + 0.175) == Approx(0.6 * still.head_nod).epsilon(0.05));
  CHECK(roll(0.3 + 0.175) * roll(2.4 + 0.175) < 0);
  CHECK(roll(2.4 + 0.175) * roll(2.82 + 0.175) < 0);
  CHECK(pitch(1.8) == 0.0f);  // the pause

  // The slow sway is half as large in the pause as within the phrases.
  AnimOptions sway;
  sway.head_nod = 0;
  const Performance q(u, m, sway);
  viseme::Utterance silent = u;
  silent.words.clear();
  silent.visemes = {{"sil", 0, 4.0}};
  const Performance r(silent, m, sway);
  const auto ratio = [&](double t) {
    BodyPose a, b;
    q.sample(t, w, &a);
    r.sample(t, w, &b);
    return std::abs(b.yaw) > 1e-4f ? a.yaw / b.yaw : 1.0f;
  };
  CHECK(ratio(1.8) == Approx(0.5).epsilon(0.01));
  CHECK(ratio(2.9) == Approx(1.0).epsilon(0.01));
  // Idle off: still.
  const Performance off(u, m, quiet());
  BodyPose h;
  off.sample(0.475, w, &h);
  CHECK(h.pitch == 0.0f);
}

TEST_CASE("the body breathes by the phrases, shrugs at accents and shifts its weight",
          "[anim][animation]") {
  // Two phrases (0.6-2.2 s and 3.0-4.0 s; the second's long word an accent) in 6 s.
  viseme::Utterance u;
  u.set = viseme::VisemeSet::kOculus;
  u.words = {{"one", 0.6, 1.0},   {"two", 1.02, 2.2},    {"three", 3.0, 3.2},
             {"four", 3.22, 3.4}, {"fiiive", 3.42, 3.9}, {"six", 3.92, 4.0}};
  u.visemes = {{"sil", 0, 0.6}, {"aa", 0.6, 2.2}, {"sil", 2.2, 3.0}, {"aa", 3.0, 4.0}};
  u.duration = 6.0;
  const Mapping m = Mapping::for_rig(face().shape_names());
  const AnimOptions o;
  const Performance p(u, m, o);
  std::vector<float> w(p.shape_names().size());
  const auto at = [&](double t) {
    BodyPose b;
    p.sample(t, w, &b);
    return b;
  };
  // In [0, depth], at rest at both ends, continuous (100 Hz steps move it little).
  float last = 0, lean_peak = 0;
  for (double t = 0; t <= p.duration(); t += 0.01) {
    const BodyPose b = at(t);
    CHECK(b.breath >= 0.0f);
    CHECK(b.breath <= o.breath_depth);
    CHECK(std::abs(b.breath - last) < 0.03f);
    CHECK(std::abs(b.lean) <= o.body_lean);
    lean_peak = std::max(lean_peak, std::abs(b.lean));
    last = b.breath;
  }
  CHECK(lean_peak > 0.0f);
  CHECK(at(0).breath == 0.0f);
  CHECK(at(p.duration()).breath == 0.0f);
  // Breathed in just before each phrase, out while it lasts.
  CHECK(at(0.6).breath == Approx(1.0).margin(0.02));
  CHECK(at(2.2).breath < at(1.0).breath - 0.15f);
  CHECK(at(3.0).breath == Approx(1.0).margin(0.02));
  CHECK(at(2.6).breath < at(2.9).breath);
  // A shrug at the accented word only.
  CHECK(at(1.0).shrug == 0.0f);
  CHECK(at(3.42 + 0.25).shrug == Approx(o.shrug).epsilon(0.05));
  // weights.json carries the body beside the head, frame by frame.
  const auto j = nlohmann::json::parse(to_json(bake(p, 50)));
  REQUIRE(j["body"].size() == j["head"].size());
  CHECK(j["body"][30][0].get<float>() == Approx(at(0.6).breath));
  // Idle off: still.
  const Performance off(u, m, quiet());
  BodyPose b;
  off.sample(0.6, w, &b);
  CHECK(b.breath == 0.0f);
  CHECK(b.lean == 0.0f);
}

TEST_CASE("idle life is seeded and blinks close, hold and open", "[anim][animation]") {
  AnimOptions o;
  const IdleLife a = idle_life(20, {}, o), b = idle_life(20, {}, o);
  CHECK(a.blinks == b.blinks);
  REQUIRE(a.blinks.size() >= 3);
  o.seed = 2;
  CHECK(idle_life(20, {}, o).blinks != a.blinks);
  const double t = a.blinks[1];
  CHECK(blink_at(a, o, t - o.blink_close - 1e-3) == 0.0f);
  CHECK(blink_at(a, o, t + 0.5 * o.blink_hold) == 1.0f);
  CHECK(blink_at(a, o, t + o.blink_hold + o.blink_open + 1e-3) == 0.0f);
  CHECK(gaze_at(a, 0.0) == std::array<float, 2>{0.0f, 0.0f});
  CHECK(gaze_at(a, 20.0) == std::array<float, 2>{0.0f, 0.0f});
  CHECK(head_at(a, o, 0.0).yaw == 0.0f);
}

TEST_CASE("closure damps expressions only on its way to contact", "[anim][animation]") {
  CHECK(closure_keep(0.0f) == 1.0f);
  CHECK(closure_keep(0.2f) == 1.0f);
  CHECK(closure_keep(0.55f) == Approx(0.5));
  CHECK(closure_keep(0.9f) == Approx(0.0).margin(1e-6));
  CHECK(closure_keep(1.0f) == 0.0f);
}
