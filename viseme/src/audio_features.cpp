// MFCCs with FFTW: see docs/algorithms.md#audio-features.
#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <numbers>

#include "features.hpp"

namespace facecast::viseme::detail {
namespace {

std::mutex g_planner;  // FFTW's planner (plan creation and destruction) is not thread-safe

double hz_to_mel(double hz) {
  return 2595.0 * std::log10(1.0 + hz / 700.0);
}
double mel_to_hz(double mel) {
  return 700.0 * (std::pow(10.0, mel / 2595.0) - 1.0);
}

}  // namespace

MfccAnalyzer::MfccAnalyzer(int rate, const FeatureConfig& c) : config_(c) {
  const auto win = static_cast<std::size_t>(std::lround(c.frame_seconds * rate));
  hop_ = static_cast<std::size_t>(std::lround(c.hop_seconds * rate));
  fft_size_ = 1;
  while (fft_size_ < win) fft_size_ *= 2;
  window_.resize(win);
  for (std::size_t i = 0; i < win; ++i)
    window_[i] =
        static_cast<float>(0.54 - 0.46 * std::cos(2 * std::numbers::pi * static_cast<double>(i) /
                                                  static_cast<double>(win - 1)));
  // Triangular mel filters between low_hz and min(high_hz, Nyquist), on the FFT bins.
  const double high = std::min(c.high_hz, rate / 2.0);
  const double m0 = hz_to_mel(c.low_hz), m1 = hz_to_mel(high);
  const std::size_t bins = fft_size_ / 2 + 1;
  mel_.resize(static_cast<std::size_t>(c.mel_bands));
  for (int b = 0; b < c.mel_bands; ++b) {
    const double lo = mel_to_hz(m0 + (m1 - m0) * b / (c.mel_bands + 1));
    const double mid = mel_to_hz(m0 + (m1 - m0) * (b + 1) / (c.mel_bands + 1));
    const double hi = mel_to_hz(m0 + (m1 - m0) * (b + 2) / (c.mel_bands + 1));
    for (std::size_t k = 0; k < bins; ++k) {
      const double hz = static_cast<double>(k) * rate / static_cast<double>(fft_size_) / c.warp;
      double w = 0;
      if (hz > lo && hz <= mid) w = (hz - lo) / (mid - lo);
      if (hz > mid && hz < hi) w = (hi - hz) / (hi - mid);
      if (w > 0)
        mel_[static_cast<std::size_t>(b)].push_back({static_cast<int>(k), static_cast<float>(w)});
    }
  }
  dct_.resize(static_cast<std::size_t>(c.cepstra * c.mel_bands));
  for (int q = 0; q < c.cepstra; ++q)
    for (int b = 0; b < c.mel_bands; ++b)
      dct_[static_cast<std::size_t>(q * c.mel_bands + b)] = static_cast<float>(
          std::sqrt(2.0 / c.mel_bands) * std::cos(std::numbers::pi * q * (b + 0.5) / c.mel_bands));
  std::lock_guard lock(g_planner);
  in_ = fftwf_alloc_real(fft_size_);
  spectrum_ = fftwf_alloc_complex(bins);
  plan_ = fftwf_plan_dft_r2c_1d(static_cast<int>(fft_size_), in_,
                                static_cast<fftwf_complex*>(spectrum_), FFTW_ESTIMATE);
}

MfccAnalyzer::~MfccAnalyzer() {
  std::lock_guard lock(g_planner);
  fftwf_destroy_plan(plan_);
  fftwf_free(in_);
  fftwf_free(spectrum_);
}

float MfccAnalyzer::analyze(const float* frame, float* out, float* mel_out) {
  const std::size_t win = window_.size();
  double energy = 0;
  for (std::size_t i = 0; i < win; ++i) {
    energy += static_cast<double>(frame[i]) * frame[i];
    const float prev = i > 0 ? frame[i - 1] : frame[0];
    in_[i] = (frame[i] - static_cast<float>(config_.preemphasis) * prev) * window_[i];
  }
  std::fill(in_ + win, in_ + fft_size_, 0.0f);
  fftwf_execute(plan_);
  const auto* spec = static_cast<const fftwf_complex*>(spectrum_);
  float logmel[64];
  const int bands = std::min(config_.mel_bands, 64);
  for (int b = 0; b < bands; ++b) {
    double e = 0;
    for (const auto& [k, w] : mel_[static_cast<std::size_t>(b)])
      e += w * (spec[k][0] * spec[k][0] + spec[k][1] * spec[k][1]);
    logmel[b] = static_cast<float>(std::log(e + 1e-8));
  }
  if (mel_out) std::copy(logmel, logmel + bands, mel_out);
  for (int q = 0; q < config_.cepstra; ++q) {
    double s = 0;
    for (int b = 0; b < bands; ++b) s += dct_[static_cast<std::size_t>(q * bands + b)] * logmel[b];
    out[q] = static_cast<float>(s);
  }
  const double mean_square = energy / static_cast<double>(win);
  out[0] = static_cast<float>(std::log(mean_square + 1e-10));
  return static_cast<float>(10.0 * std::log10(mean_square + 1e-10));
}

Features compute_features(const std::vector<float>& samples, int rate, const FeatureConfig& c) {
  MfccAnalyzer a(rate, c);
  Features f;
  f.dims = a.dims();
  f.hop_seconds = static_cast<double>(a.hop()) / rate;
  f.frame_seconds = static_cast<double>(a.window()) / rate;
  if (samples.size() < a.window()) return f;
  const std::size_t n = (samples.size() - a.window()) / a.hop() + 1;
  f.mfcc.resize(n * static_cast<std::size_t>(f.dims));
  f.energy_db.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    f.energy_db[i] = a.analyze(samples.data() + i * a.hop(),
                               f.mfcc.data() + i * static_cast<std::size_t>(f.dims));
  return f;
}

void add_deltas(Features& f) {
  const std::size_t n = f.frames(), d = static_cast<std::size_t>(f.dims);
  std::vector<float> out(n * 2 * d);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t a = i > 0 ? i - 1 : i, b = i + 1 < n ? i + 1 : i;
    for (std::size_t q = 0; q < d; ++q) {
      out[i * 2 * d + q] = f.mfcc[i * d + q];
      out[i * 2 * d + d + q] = 0.5f * (f.mfcc[b * d + q] - f.mfcc[a * d + q]);
    }
  }
  f.mfcc = std::move(out);
  f.dims *= 2;
}

void normalize(Features& f, std::size_t from, std::size_t to) {
  const std::size_t n = f.frames();
  to = std::min(to, n);
  if (from >= to) from = 0, to = n;
  if (n == 0) return;
  const auto d = static_cast<std::size_t>(f.dims);
  const auto m = static_cast<double>(to - from);
  float emax = -1e30f;
  for (std::size_t i = from; i < to; ++i) emax = std::max(emax, f.mfcc[i * d]);
  for (std::size_t i = 0; i < n; ++i) f.mfcc[i * d] = std::max(f.mfcc[i * d] - emax, -12.0f) / 3.0f;
  for (std::size_t q = 1; q < d; ++q) {
    double mean = 0, sq = 0;
    for (std::size_t i = from; i < to; ++i) mean += f.mfcc[i * d + q];
    mean /= m;
    for (std::size_t i = from; i < to; ++i) sq += std::pow(f.mfcc[i * d + q] - mean, 2);
    const double sd = std::sqrt(sq / m) + 1e-6;
    for (std::size_t i = 0; i < n; ++i)
      f.mfcc[i * d + q] = static_cast<float>((f.mfcc[i * d + q] - mean) / sd);
  }
}

}  // namespace facecast::viseme::detail
