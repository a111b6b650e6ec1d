// Options and learned class templates of the audio-only lip-sync: see
// docs/algorithms.md#audio-lipsync.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <mutex>

#include "facecast/core/config.hpp"
#include "facecast/core/config_reader.hpp"
#include "facecast/core/error.hpp"
#include "facecast/viseme/lipsync.hpp"
#include "lipsync_features.hpp"

namespace facecast::viseme {
namespace {

constexpr std::array<std::string_view, kSoundClasses> kClassNames = {
    "sil", "closure", "fricative", "consonant", "a", "e", "i", "o", "u", "labiodental"};

std::filesystem::path templates_path() {
  if (const char* e = std::getenv("FACECAST_LIPSYNC_TEMPLATES"); e && *e) return e;
  std::error_code ec;
  if (std::filesystem::exists(FACECAST_LIPSYNC_TEMPLATES, ec)) return FACECAST_LIPSYNC_TEMPLATES;
  return FACECAST_LIPSYNC_TEMPLATES_INSTALLED;
}

}  // namespace

std::string_view to_string(SoundClass c) noexcept {
  return kClassNames[static_cast<std::size_t>(c)];
}

SoundClass parse_sound_class(std::string_view name) {
  for (std::size_t i = 0; i < kClassNames.size(); ++i)
    if (kClassNames[i] == name) return static_cast<SoundClass>(i);
  throw Error("unknown sound class '" + std::string(name) + "'");
}

const std::string& LipsyncOptions::viseme(VisemeSet set, SoundClass c) const {
  const auto i = static_cast<std::size_t>(c);
  return set == VisemeSet::kZh15 ? zh15[i] : set == VisemeSet::kMpeg4 ? mpeg4[i] : oculus[i];
}

LipsyncOptions load_lipsync_options() {
  ConfigReader c = ConfigReader::open(config_path("viseme/lipsync.json"));
  LipsyncOptions o;
  c.read("adapt_seconds", o.adapt_seconds)
      .read("prior_frames", o.prior_frames)
      .read("silence_range", o.silence_range)
      .read("silence_max_db", o.silence_max_db)
      .read("closure_max", o.closure_max)
      .read("closure_entry_db", o.closure_entry_db)
      .read("murmur_nasal_db", o.murmur_nasal_db)
      .read("murmur_dull_db", o.murmur_dull_db)
      .read("murmur_dip_db", o.murmur_dip_db)
      .read("murmur_voicing", o.murmur_voicing)
      .read("murmur_openness", o.murmur_openness)
      .read("closure_bias", o.closure_bias)
      .read("burst_max_db", o.burst_max_db)
      .read("labiodental_max_db", o.labiodental_max_db)
      .read("labiodental_bias", o.labiodental_bias)
      .read("lookahead_frames", o.lookahead_frames)
      .read("context_frames", o.context_frames)
      .read("switch_margin", o.switch_margin)
      .read("jaw_range_db", o.jaw_range_db)
      .read("jaw_min", o.jaw_min)
      .read("jaw_max", o.jaw_max)
      .read("jaw_openness", o.jaw_openness)
      .read("delay", o.delay)
      .read("window", o.window);
  c.section("visemes").read("oculus", o.oculus).read("zh15", o.zh15).read("mpeg4", o.mpeg4);
  if (o.lookahead_frames < 0 || o.lookahead_frames > 10)
    c.fail("lookahead_frames", "must be 0..10 (10 ms frames; latency budget 150 ms)");
  if (o.context_frames < 0 || o.context_frames > 20) c.fail("context_frames", "must be 0..20");
  if (o.adapt_seconds <= 0) c.fail("adapt_seconds", "must be > 0");
  if (o.jaw_range_db <= 0) c.fail("jaw_range_db", "must be > 0");
  if (o.jaw_openness < 0 || o.jaw_openness > 1) c.fail("jaw_openness", "must be 0..1");
  if (o.murmur_voicing < 0 || o.murmur_voicing > 1) c.fail("murmur_voicing", "must be 0..1");
  if (o.delay < 0 || o.delay > 0.1) c.fail("delay", "must be 0..0.1 s (latency budget 150 ms)");
  c.reject_unknown();
  return o;
}

LipsyncTemplates LipsyncTemplates::parse(std::string_view json, std::string_view source) {
  const std::string where(source);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(json);
  } catch (const nlohmann::json::exception& e) {
    throw Error(where + ": not JSON (" + e.what() + ")");
  }
  LipsyncTemplates t;
  try {
    t.dims = j.at("dims").get<int>();
    if (t.dims != detail::kLipsyncDims)
      throw Error(where + ": dims " + std::to_string(t.dims) + ", this build computes " +
                  std::to_string(detail::kLipsyncDims) + " (regenerate it)");
    t.cepstral_mean = j.at("cepstral_mean").get<std::vector<float>>();
    t.log_prior.fill(-std::numeric_limits<double>::infinity());
    for (const auto& cls : j.at("classes")) {
      const auto k = static_cast<std::size_t>(parse_sound_class(cls.at("name").get<std::string>()));
      t.log_prior[k] = std::log(cls.at("prior").get<double>());
      for (const auto& c : cls.at("components")) {
        Component m;
        m.log_weight = std::log(c.at("weight").get<double>());
        m.mean = c.at("mean").get<std::vector<float>>();
        const auto var = c.at("var").get<std::vector<float>>();
        if (m.mean.size() != static_cast<std::size_t>(t.dims) || var.size() != m.mean.size())
          throw Error(where + ": class " + std::string(kClassNames[k]) + ": mean/var size");
        m.log_norm = -0.5 * t.dims * std::log(2 * 3.141592653589793);
        for (float v : var) {
          m.inv_var.push_back(1.0f / v);
          m.log_norm -= 0.5 * std::log(v);
        }
        t.classes[k].push_back(std::move(m));
      }
    }
  } catch (const nlohmann::json::exception& e) {
    throw Error(where + ": " + e.what());
  }
  return t;
}

const LipsyncTemplates& LipsyncTemplates::builtin() {
  static std::once_flag once;
  static LipsyncTemplates table;
  std::call_once(once, [] {
    const std::filesystem::path p = templates_path();
    std::error_code ec;
    if (!std::filesystem::exists(p, ec))
      throw Error(p.string() + ": lip-sync templates missing (built by facecast_viseme_lipsyncgen)",
                  ErrorCode::kNotFound);
    table = parse(load_json(p).dump(), p.string());
  });
  return table;
}

void LipsyncTemplates::score(const float* x, std::array<double, kSoundClasses>& out) const {
  for (std::size_t k = 0; k < classes.size(); ++k) {
    double best = -std::numeric_limits<double>::infinity(), sum = 0;
    std::array<double, 16> ll{};
    const std::size_t n = std::min<std::size_t>(classes[k].size(), ll.size());
    for (std::size_t m = 0; m < n; ++m) {
      const Component& c = classes[k][m];
      double d = 0;
      for (int q = 0; q < dims; ++q) {
        const double e = x[q] - c.mean[static_cast<std::size_t>(q)];
        d += e * e * c.inv_var[static_cast<std::size_t>(q)];
      }
      ll[m] = c.log_weight + c.log_norm - 0.5 * d;
      best = std::max(best, ll[m]);
    }
    for (std::size_t m = 0; m < n; ++m) sum += std::exp(ll[m] - best);
    out[k] = n == 0 ? -std::numeric_limits<double>::infinity() : best + std::log(sum);
  }
}

}  // namespace facecast::viseme
