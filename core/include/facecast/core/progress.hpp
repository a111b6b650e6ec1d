#pragma once
// Progress reporting for long work (rig builds, renders). Libraries call it; the CLI draws a bar,
// the server stores it in the job. `fraction` is in [0,1]; `stage` names what is running.
#include <functional>
#include <string_view>

namespace facecast {

using ProgressFn = std::function<void(std::string_view stage, double fraction)>;

inline void report(const ProgressFn& fn, std::string_view stage, double fraction) {
  if (fn) fn(stage, fraction);
}

}  // namespace facecast
