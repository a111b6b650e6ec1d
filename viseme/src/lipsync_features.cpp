// Frame features of the audio-only lip-sync: see docs/algorithms.md#audio-lipsync.
#include "lipsync_features.hpp"

#include <algorithm>
#include <cmath>

namespace facecast::viseme::detail {
namespace {

constexpr double kFloorRise = 2.0;    // dB per second the silence floor creeps up
constexpr double kVoicedOver = 12.0;  // dB over the floor a frame needs to update the level
constexpr float kVoicedMin = 0.5f;    // voicing a frame needs to update the level

// Peak normalised autocorrelation over pitch lags of 60..400 Hz, on the frame decimated to about
// 8 kHz (pairs averaged), mean removed.
float voicing(const float* x, std::size_t n, int rate) {
  const int step = std::max(1, rate / 8000);
  const int r8 = rate / step;
  float y[1024];
  const std::size_t m = std::min<std::size_t>(n / static_cast<std::size_t>(step), 1024);
  double mean = 0;
  for (std::size_t i = 0; i < m; ++i) {
    float s = 0;
    for (int k = 0; k < step; ++k)
      s += x[i * static_cast<std::size_t>(step) + static_cast<std::size_t>(k)];
    y[i] = s / static_cast<float>(step);
    mean += y[i];
  }
  mean /= static_cast<double>(std::max<std::size_t>(m, 1));
  for (std::size_t i = 0; i < m; ++i) y[i] -= static_cast<float>(mean);
  const auto lag0 = static_cast<std::size_t>(r8 / 400), lag1 = static_cast<std::size_t>(r8 / 60);
  float best = 0;
  for (std::size_t lag = lag0; lag <= lag1 && lag + 8 < m; ++lag) {
    double xy = 0, xx = 0, yy = 0;
    for (std::size_t i = 0; i + lag < m; ++i) {
      xy += static_cast<double>(y[i]) * y[i + lag];
      xx += static_cast<double>(y[i]) * y[i];
      yy += static_cast<double>(y[i + lag]) * y[i + lag];
    }
    if (xx > 1e-12 && yy > 1e-12)
      best = std::max(best, static_cast<float>(xy / std::sqrt(xx * yy)));
  }
  return best;
}

}  // namespace

FeatureStream::FeatureStream(int rate, const LipsyncOptions& o, const std::vector<float>& prior)
    : options_(o), mfcc_(std::make_unique<MfccAnalyzer>(rate)), rate_(rate) {
  hop_seconds_ = static_cast<double>(mfcc_->hop()) / rate;
  window_seconds_ = static_cast<double>(mfcc_->window()) / rate;
  for (int q = 0; q < kLipsyncCepstra && q < static_cast<int>(prior.size()); ++q)
    cep_mean_[static_cast<std::size_t>(q)] = prior[static_cast<std::size_t>(q)];
  cep_weight_ = prior.empty() ? 0 : o.prior_frames;
  // Band centres of MfccAnalyzer's default filterbank (FeatureConfig: 26 bands, 80 Hz ..
  // min(7.6 kHz, Nyquist), evenly spaced in mel).
  const FeatureConfig fc;
  const auto mel = [](double hz) { return 2595.0 * std::log10(1.0 + hz / 700.0); };
  const double m0 = mel(fc.low_hz), m1 = mel(std::min(fc.high_hz, rate / 2.0));
  for (int b = 0; b < fc.mel_bands; ++b)
    centre_hz_.push_back(static_cast<float>(
        700.0 * (std::pow(10.0, (m0 + (m1 - m0) * (b + 1) / (fc.mel_bands + 1)) / 2595.0) - 1)));
  const auto first_at = [&](double hz) {
    int b = 0;
    while (b < fc.mel_bands && centre_hz_[static_cast<std::size_t>(b)] < hz) ++b;
    return b;
  };
  bass0_ = first_at(150), bass1_ = first_at(500), mid0_ = first_at(1000), mid1_ = first_at(2200);
  f10_ = first_at(250), f11_ = first_at(1000);
  tr0_ = first_at(2500), tr1_ = first_at(4000);
}

RawFrame FeatureStream::analyze(const float* frame) {
  RawFrame r;
  const std::size_t win = mfcc_->window();
  r.time = static_cast<double>(frames_++) * hop_seconds_ + window_seconds_ / 2;
  float c[16], m[64];
  r.level_db = mfcc_->analyze(frame, c, m);
  const auto band_db = [&](int from, int to) {
    double e = 1e-12;
    for (int b = from; b < to; ++b) e += std::exp(static_cast<double>(m[b]));
    return static_cast<float>(10 * std::log10(e));
  };
  r.bass_db = band_db(bass0_, bass1_);
  r.mid_db = band_db(mid0_, mid1_);
  r.treble_db = band_db(tr0_, tr1_);
  double w = 0, wf = 0;
  for (int b = f10_; b < f11_; ++b) {
    const double e = std::exp(2.0 * static_cast<double>(m[b]));
    w += e, wf += e * centre_hz_[static_cast<std::size_t>(b)];
  }
  r.f1_hz = w > 0 ? static_cast<float>(wf / w) : 0.0f;
  std::copy(c + 1, c + 1 + kLipsyncCepstra, r.cep.begin());
  int crossings = 0;
  for (std::size_t i = 1; i < win; ++i) crossings += (frame[i] >= 0) != (frame[i - 1] >= 0);
  r.zcr = static_cast<float>(crossings) / static_cast<float>(win);
  r.voicing = voicing(frame, win, rate_);
  return r;
}

// Speaker normalisation: cepstral mean over sounding frames, speech level over voiced ones, both
// cumulative until adapt_seconds of weight and exponential after; the floor tracks the minimum.
void FeatureStream::adapt(const RawFrame& f) {
  if (!started_) floor_db_ = f.level_db, started_ = true;
  floor_db_ = std::min(static_cast<double>(f.level_db), floor_db_ + kFloorRise * hop_seconds_);
  const double cap = options_.adapt_seconds / hop_seconds_;
  if (f.level_db > floor_db_ + kVoicedOver && f.voicing > kVoicedMin &&
      (speech_weight_ == 0 || f.level_db > speech_db_ - options_.silence_max_db)) {
    speech_weight_ = std::min(speech_weight_ + 1, cap);
    speech_db_ += (f.level_db - speech_db_) / speech_weight_;
  }
  if (f.level_db > floor_db_ + kVoicedOver) {
    cep_weight_ = std::min(cep_weight_ + 1, cap + options_.prior_frames);
    for (int q = 0; q < kLipsyncCepstra; ++q) {
      auto& m = cep_mean_[static_cast<std::size_t>(q)];
      m += (f.cep[static_cast<std::size_t>(q)] - m) / cep_weight_;
    }
  }
}

FeatureFrame FeatureStream::complete(const RawFrame& prev, const RawFrame& cur,
                                     const RawFrame& next) {
  adapt(cur);
  FeatureFrame f;
  f.time = cur.time;
  const double speech = speech_db_;
  const double threshold = std::max(floor_db_ + options_.silence_range * (speech - floor_db_),
                                    speech - options_.silence_max_db);
  f.silent = speech_weight_ == 0 || cur.level_db < threshold;
  f.settled = speech_weight_ >= 10;
  const double bottom = speech - options_.jaw_range_db;
  f.loudness =
      static_cast<float>(std::clamp((cur.level_db - bottom) / (speech + 3 - bottom), 0.0, 1.0));
  const std::size_t n = kLipsyncCepstra;
  for (std::size_t q = 0; q < n; ++q) {
    f.x[q] = static_cast<float>(cur.cep[q] - cep_mean_[q]);
    f.x[n + q] = 0.5f * (next.cep[q] - prev.cep[q]);
  }
  f.x[2 * n] = static_cast<float>((cur.level_db - speech) / 10);
  f.x[2 * n + 1] = (next.level_db - prev.level_db) / 20;
  f.x[2 * n + 2] = cur.voicing;
  f.x[2 * n + 3] = cur.zcr * 4;
  f.level = static_cast<float>(cur.level_db - speech);
  f.voicing = cur.voicing;
  f.nasal = cur.bass_db - cur.mid_db;
  f.dull = cur.bass_db - cur.treble_db;
  f.openness = static_cast<float>(std::clamp((cur.f1_hz - f1_lo_) / (f1_hi_ - f1_lo_), 0.0, 1.0));
  f.x[2 * n + 4] = f.openness;
  f.x[2 * n + 5] = std::clamp(f.nasal, -40.0f, 40.0f) / 20;
  return f;
}

void FeatureStream::push(const float* samples, std::size_t n, std::vector<FeatureFrame>& out) {
  buffer_.insert(buffer_.end(), samples, samples + n);
  const std::size_t win = mfcc_->window(), hop = mfcc_->hop();
  std::size_t at = 0;
  for (; at + win <= buffer_.size(); at += hop) {
    const RawFrame r = analyze(buffer_.data() + at);
    if (!pending_.empty()) {
      const RawFrame cur = pending_.front();
      pending_.pop_front();
      out.push_back(complete(has_previous_ ? previous_ : cur, cur, r));
      previous_ = cur;
      has_previous_ = true;
    }
    pending_.push_back(r);
  }
  buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(at));
}

void FeatureStream::finish(std::vector<FeatureFrame>& out) {
  while (!pending_.empty()) {
    const RawFrame cur = pending_.front();
    pending_.pop_front();
    out.push_back(complete(has_previous_ ? previous_ : cur, cur, cur));
    previous_ = cur;
    has_previous_ = true;
  }
}

}  // namespace facecast::viseme::detail
