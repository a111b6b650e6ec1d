#pragma once
// Frame-wise acoustic features of mono audio: MFCCs (FFTW real FFT, mel filterbank, DCT-II) and
// log energy. See docs/algorithms.md#audio-features.
#include <cstddef>
#include <cstdint>
#include <vector>

struct fftwf_plan_s;

namespace facecast::viseme::detail {

struct FeatureConfig {
  double frame_seconds = 0.025;  // Hamming window length
  double hop_seconds = 0.010;
  int mel_bands = 26;
  int cepstra = 13;  // c0 .. c12; c0 is replaced by the frame's log energy
  double low_hz = 80, high_hz = 7600;
  double preemphasis = 0.97;
  /// Vocal tract length warp: the filter meant for frequency F reads the spectrum at warp x F
  /// (> 1 for a shorter vocal tract / higher formants than the reference).
  double warp = 1.0;
};

/// Features of a whole signal: frame i covers samples [i*hop, i*hop + window); its time is
/// the window's centre.
struct Features {
  int dims = 0;
  double hop_seconds = 0, frame_seconds = 0;
  std::vector<float> mfcc;       // frames x dims, row-major; [0] = log energy (natural log)
  std::vector<float> energy_db;  // per frame, 10 log10(mean square)
  std::size_t frames() const { return energy_db.size(); }
  const float* row(std::size_t i) const { return mfcc.data() + i * static_cast<std::size_t>(dims); }
  double time(std::size_t i) const {
    return static_cast<double>(i) * hop_seconds + frame_seconds / 2;
  }
};

/// One analysis frame at a time (the streaming path uses it directly). Owns its FFTW plan and
/// buffers: one per thread; plan creation is serialized inside (FFTW's planner is not
/// thread-safe, its execution is).
class MfccAnalyzer {
 public:
  MfccAnalyzer(int sample_rate, const FeatureConfig& config = {});
  ~MfccAnalyzer();
  MfccAnalyzer(const MfccAnalyzer&) = delete;
  MfccAnalyzer& operator=(const MfccAnalyzer&) = delete;

  std::size_t window() const { return window_.size(); }
  std::size_t hop() const { return hop_; }
  int dims() const { return config_.cepstra; }
  /// `frame` holds window() samples; writes dims() values (log energy first) and returns the
  /// frame's level in dB. `mel_out`, when given, receives the mel_bands log energies.
  float analyze(const float* frame, float* out, float* mel_out = nullptr);

 private:
  FeatureConfig config_;
  std::size_t fft_size_ = 0, hop_ = 0;
  std::vector<float> window_;
  std::vector<std::vector<std::pair<int, float>>> mel_;  // per band: (bin, weight)
  std::vector<float> dct_;                               // cepstra x mel_bands
  float* in_ = nullptr;
  void* spectrum_ = nullptr;  // fftwf_complex[fft_size/2+1]
  fftwf_plan_s* plan_ = nullptr;
};

/// Features of a whole signal (frames that fit entirely; a short signal gives none).
Features compute_features(const std::vector<float>& samples, int sample_rate,
                          const FeatureConfig& config = {});

/// Cepstral mean and variance normalisation (columns 1.. of mfcc; the energy column is centred on
/// its maximum instead, so silence stays low), the statistics taken over frames [from, to) (all
/// when empty) and applied to every frame.
void normalize(Features& f, std::size_t from = 0, std::size_t to = SIZE_MAX);

/// Appends first differences (x[i+1] - x[i-1]) / 2 of every column: dims doubles.
void add_deltas(Features& f);

}  // namespace facecast::viseme::detail
