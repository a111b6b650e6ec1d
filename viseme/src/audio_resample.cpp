// Band-limited resampling: Kaiser-windowed sinc, see docs/algorithms.md#audio-in.
#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>

#include "facecast/core/error.hpp"
#include "facecast/viseme/audio.hpp"

namespace facecast::viseme {
namespace {

constexpr int kZeroCrossings = 16;
constexpr double kBeta = 8.0;      // Kaiser window: about 80 dB stop-band attenuation
constexpr double kRolloff = 0.95;  // cut-off as a fraction of the lower Nyquist frequency
constexpr int kTableSteps = 512;   // filter table resolution per input sample

double bessel_i0(double x) {
  double sum = 1, term = 1;
  for (int k = 1; k < 40; ++k) {
    term *= (x / (2 * k)) * (x / (2 * k));
    sum += term;
    if (term < 1e-12 * sum) break;
  }
  return sum;
}

// The filter h(t) for t = 0 .. half_width input samples (symmetric), tabulated.
struct Filter {
  double cutoff = 1;      // normalized to the input rate's Nyquist frequency
  double half_width = 0;  // input samples
  std::vector<float> table;
  explicit Filter(int from, int to) {
    cutoff = kRolloff * std::min(1.0, static_cast<double>(to) / from);
    half_width = kZeroCrossings / cutoff;
    const int n = static_cast<int>(std::ceil(half_width * kTableSteps)) + 2;
    table.resize(static_cast<std::size_t>(n));
    const double i0 = bessel_i0(kBeta);
    for (int i = 0; i < n; ++i) {
      const double t = static_cast<double>(i) / kTableSteps;
      const double r = t / half_width;
      if (r >= 1) {
        table[static_cast<std::size_t>(i)] = 0;
        continue;
      }
      const double x = std::numbers::pi * cutoff * t;
      const double sinc = t == 0 ? 1.0 : std::sin(x) / x;
      table[static_cast<std::size_t>(i)] =
          static_cast<float>(cutoff * sinc * bessel_i0(kBeta * std::sqrt(1 - r * r)) / i0);
    }
  }
  float operator()(double t) const {
    const double p = std::abs(t) * kTableSteps;
    const auto i = static_cast<std::size_t>(p);
    if (i + 1 >= table.size()) return 0;
    const float f = static_cast<float>(p - static_cast<double>(i));
    return table[i] + f * (table[i + 1] - table[i]);
  }
};

const Filter& filter_for(int from, int to) {
  // The few rate pairs a process sees are cached; thread_local keeps this free of locks.
  thread_local std::vector<std::pair<std::pair<int, int>, std::unique_ptr<Filter>>> cache;
  for (const auto& [key, f] : cache)
    if (key == std::pair{from, to}) return *f;
  if (cache.size() > 16) cache.erase(cache.begin());
  cache.emplace_back(std::pair{from, to}, std::make_unique<Filter>(from, to));
  return *cache.back().second;
}

}  // namespace

StreamResampler::StreamResampler(int from_rate, int to_rate) : from_(from_rate), to_(to_rate) {
  if (from_rate < 1000 || to_rate < 1000 || from_rate > 768000 || to_rate > 768000)
    throw Error("sample rate " + std::to_string(from_rate) + " -> " + std::to_string(to_rate) +
                " Hz is outside 1000..768000");
  if (from_ != to_) {
    const double half = filter_for(from_, to_).half_width;
    buffer_.assign(static_cast<std::size_t>(std::ceil(half)), 0.0f);  // zeros before the start
  }
}

void StreamResampler::push(const float* chunk, std::size_t n, std::vector<float>& out) {
  if (from_ == to_) {
    out.insert(out.end(), chunk, chunk + n);
    return;
  }
  const Filter& h = filter_for(from_, to_);
  buffer_.insert(buffer_.end(), chunk, chunk + n);
  const double step = static_cast<double>(from_) / to_;
  const double half = h.half_width;
  const double lead = std::ceil(half);  // buffer_ starts with `lead` samples of history
  // Output at input position next_ + lead needs samples up to next_ + lead + half.
  while (next_ + lead + half < static_cast<double>(buffer_.size())) {
    const double x = next_ + lead;
    const auto lo = static_cast<std::ptrdiff_t>(std::ceil(x - half));
    const auto hi = static_cast<std::ptrdiff_t>(std::floor(x + half));
    double acc = 0;
    for (std::ptrdiff_t k = std::max<std::ptrdiff_t>(lo, 0); k <= hi; ++k)
      acc += buffer_[static_cast<std::size_t>(k)] * h(x - static_cast<double>(k));
    out.push_back(static_cast<float>(acc));
    next_ += step;
  }
  // Drop input that no future output reaches, keeping `lead` samples of history.
  const auto drop = static_cast<std::size_t>(std::max(0.0, std::floor(next_)));
  if (drop > 0) {
    buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(drop));
    next_ -= static_cast<double>(drop);
  }
}

std::vector<float> resample(const std::vector<float>& in, int from_rate, int to_rate) {
  if (from_rate == to_rate) return in;
  StreamResampler r(from_rate, to_rate);
  std::vector<float> out;
  const auto expected =
      static_cast<std::size_t>(std::llround(static_cast<double>(in.size()) * to_rate / from_rate));
  out.reserve(expected + 1);
  r.push(in.data(), in.size(), out);
  const std::vector<float> tail(
      static_cast<std::size_t>(filter_for(from_rate, to_rate).half_width) + 2, 0.0f);
  r.push(tail.data(), tail.size(), out);
  out.resize(expected, 0.0f);
  return out;
}

}  // namespace facecast::viseme
