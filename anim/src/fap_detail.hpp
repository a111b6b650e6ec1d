#pragma once
// What fap.cpp and fap_motion.cpp share.
#include <cstddef>

namespace facecast::anim::detail {

inline constexpr double kAu = 1e-5;  // radians per angular unit
inline constexpr int kHeadPitch = 48, kHeadYaw = 49, kHeadRoll = 50;

/// FAP n's index in a frame's arrays.
constexpr std::size_t at(int fap) {
  return static_cast<std::size_t>(fap - 1);
}

constexpr bool is_head(int fap) {
  return fap >= kHeadPitch && fap <= kHeadRoll;
}

}  // namespace facecast::anim::detail
