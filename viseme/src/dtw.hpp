#pragma once
// Dynamic time warping of two feature sequences with slope constraints, free stretching inside
// silences and a search band. See docs/algorithms.md#forced-alignment.
#include <utility>
#include <vector>

#include "features.hpp"

namespace facecast::viseme::detail {

struct DtwConfig {
  double band = 0.25;    // half-width of the band around the diagonal, fraction of max(n, m) ...
  int band_frames = 50;  // ... plus this many frames, at most max_band_frames
  int max_band_frames = 600;
  double hold_penalty = 2.0;  // added to a (1,0)/(0,1) step where only one of the frames is silent
};

/// The warping path from (0, 0) to (n-1, m-1) as (x frame, y frame) pairs, x and y rows of
/// normalized features. Steps: (1,1) and the slope-limited (2,1), (1,2) everywhere; (1,0) and
/// (0,1) only where a frame is silent (`free_x[i] || free_y[j]`; free when both are, else at
/// `hold_penalty`), so pauses of any length stretch while speech is warped by at most 2:1 locally.
/// `cost`, when given, receives the path's accumulated cost divided by n + m.
std::vector<std::pair<int, int>> dtw_path(const Features& x, const Features& y,
                                          const std::vector<bool>& free_x,
                                          const std::vector<bool>& free_y, const DtwConfig& c,
                                          double* cost = nullptr);

/// Per frame: silent (level below the threshold of the signal's own level distribution:
/// floor + range x (loud - floor), at most max_db below loud; floor, loud = 5th, 95th percentile).
std::vector<bool> silent_frames(const Features& f, double range, double max_db);

}  // namespace facecast::viseme::detail
