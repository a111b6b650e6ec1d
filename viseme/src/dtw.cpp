// DTW with slope constraints: see docs/algorithms.md#forced-alignment.
#include "dtw.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "facecast/core/error.hpp"

namespace facecast::viseme::detail {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// The band: row i holds columns [lo[i], lo[i] + width) (clamped to 0..m-1 on access).
struct Band {
  int n = 0, m = 0, half = 0;
  std::vector<int> lo;
  std::vector<float> cost;
  std::vector<std::uint8_t> move;
  Band(int n_, int m_, int half_) : n(n_), m(m_), half(half_), lo(static_cast<std::size_t>(n_)) {
    for (int i = 0; i < n; ++i) {
      const double centre = n > 1 ? static_cast<double>(i) * (m - 1) / (n - 1) : 0.0;
      lo[static_cast<std::size_t>(i)] = static_cast<int>(std::lround(centre)) - half;
    }
    cost.assign(static_cast<std::size_t>(n) * width(), kInf);
    move.assign(cost.size(), 0);
  }
  std::size_t width() const { return static_cast<std::size_t>(2 * half + 1); }
  bool inside(int i, int j) const {
    return i >= 0 && i < n && j >= 0 && j < m && j >= lo[static_cast<std::size_t>(i)] &&
           j < lo[static_cast<std::size_t>(i)] + 2 * half + 1;
  }
  std::size_t at(int i, int j) const {
    return static_cast<std::size_t>(i) * width() +
           static_cast<std::size_t>(j - lo[static_cast<std::size_t>(i)]);
  }
  float D(int i, int j) const { return inside(i, j) ? cost[at(i, j)] : kInf; }
};

float distance(const Features& x, int i, const Features& y, int j) {
  const float* a = x.row(static_cast<std::size_t>(i));
  const float* b = y.row(static_cast<std::size_t>(j));
  float s = 0;
  for (int k = 0; k < x.dims; ++k) s += (a[k] - b[k]) * (a[k] - b[k]);
  return std::sqrt(s);
}

}  // namespace

std::vector<std::pair<int, int>> dtw_path(const Features& x, const Features& y,
                                          const std::vector<bool>& free_x,
                                          const std::vector<bool>& free_y, const DtwConfig& c,
                                          double* cost) {
  const int n = static_cast<int>(x.frames()), m = static_cast<int>(y.frames());
  if (n == 0 || m == 0) throw Error("alignment: no audio frames to align");
  const int half = std::min(c.max_band_frames, static_cast<int>(c.band * std::max(n, m))) +
                   c.band_frames + std::abs(n - m) / 8;
  Band b(n, m, half);
  // Moves: 1 = (1,1), 2 = (2,1), 3 = (1,2), 4 = (1,0), 5 = (0,1).
  for (int i = 0; i < n; ++i) {
    const int j0 = std::max(0, b.lo[static_cast<std::size_t>(i)]);
    const int j1 = std::min(m - 1, b.lo[static_cast<std::size_t>(i)] + 2 * half);
    for (int j = j0; j <= j1; ++j) {
      const float d = distance(x, i, y, j);
      if (i == 0 && j == 0) {
        b.cost[b.at(0, 0)] = d;
        continue;
      }
      float best = kInf;
      std::uint8_t mv = 0;
      const auto take = [&](float v, std::uint8_t code) {
        if (v < best) best = v, mv = code;
      };
      take(b.D(i - 1, j - 1) + 2 * d, 1);
      if (i >= 2 && j >= 1 && b.D(i - 2, j - 1) < kInf)
        take(b.D(i - 2, j - 1) + 2 * distance(x, i - 1, y, j) + d, 2);
      if (i >= 1 && j >= 2 && b.D(i - 1, j - 2) < kInf)
        take(b.D(i - 1, j - 2) + 2 * distance(x, i, y, j - 1) + d, 3);
      const bool sx = free_x[static_cast<std::size_t>(i)], sy = free_y[static_cast<std::size_t>(j)];
      if (sx || sy) {
        const bool free = sx && sy;
        const float extra = free ? 0.0f : static_cast<float>(c.hold_penalty);
        take(b.D(i - 1, j) + d + extra, 4);
        take(b.D(i, j - 1) + d + extra, 5);
      }
      b.cost[b.at(i, j)] = best;
      b.move[b.at(i, j)] = mv;
    }
  }
  if (!(b.D(n - 1, m - 1) < kInf))
    throw Error(
        "alignment: the audio and the text's speech cannot be matched (too different "
        "in length or pace)");
  if (cost) *cost = b.D(n - 1, m - 1) / (n + m);
  std::vector<std::pair<int, int>> path;
  for (int i = n - 1, j = m - 1;;) {
    path.push_back({i, j});
    if (i == 0 && j == 0) break;
    switch (b.move[b.at(i, j)]) {
      case 1:
        --i, --j;
        break;
      case 2:
        path.push_back({i - 1, j}), i -= 2, --j;
        break;
      case 3:
        path.push_back({i, j - 1}), --i, j -= 2;
        break;
      case 4:
        --i;
        break;
      default:
        --j;
        break;
    }
  }
  std::reverse(path.begin(), path.end());
  return path;
}

std::vector<bool> silent_frames(const Features& f, double range, double max_db) {
  std::vector<float> sorted = f.energy_db;
  std::vector<bool> out(sorted.size(), true);
  if (sorted.empty()) return out;
  std::sort(sorted.begin(), sorted.end());
  const float floor = sorted[sorted.size() * 10 / 100], loud = sorted[sorted.size() * 95 / 100];
  const double threshold =
      std::max(floor + range * (loud - floor), static_cast<double>(loud) - max_db);
  for (std::size_t i = 0; i < f.frames(); ++i) out[i] = f.energy_db[i] < threshold;
  return out;
}

}  // namespace facecast::viseme::detail
