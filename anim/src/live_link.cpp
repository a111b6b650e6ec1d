#include "facecast/anim/live_link.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>

namespace facecast::anim {
namespace {

// Lower case, "_L"/"_R" suffixes spelled "left"/"right".
std::string shape_key(std::string_view name) {
  std::string s(name);
  if (s.size() > 2 && s[s.size() - 2] == '_' && (s.back() == 'L' || s.back() == 'R'))
    s = s.substr(0, s.size() - 2) + (s.back() == 'L' ? "Left" : "Right");
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace

const std::array<std::string_view, 52>& live_link_face_shapes() {
  static constexpr std::array<std::string_view, 52> kShapes = {"EyeBlinkLeft",
                                                               "EyeLookDownLeft",
                                                               "EyeLookInLeft",
                                                               "EyeLookOutLeft",
                                                               "EyeLookUpLeft",
                                                               "EyeSquintLeft",
                                                               "EyeWideLeft",
                                                               "EyeBlinkRight",
                                                               "EyeLookDownRight",
                                                               "EyeLookInRight",
                                                               "EyeLookOutRight",
                                                               "EyeLookUpRight",
                                                               "EyeSquintRight",
                                                               "EyeWideRight",
                                                               "JawForward",
                                                               "JawRight",
                                                               "JawLeft",
                                                               "JawOpen",
                                                               "MouthClose",
                                                               "MouthFunnel",
                                                               "MouthPucker",
                                                               "MouthRight",
                                                               "MouthLeft",
                                                               "MouthSmileLeft",
                                                               "MouthSmileRight",
                                                               "MouthFrownLeft",
                                                               "MouthFrownRight",
                                                               "MouthDimpleLeft",
                                                               "MouthDimpleRight",
                                                               "MouthStretchLeft",
                                                               "MouthStretchRight",
                                                               "MouthRollLower",
                                                               "MouthRollUpper",
                                                               "MouthShrugLower",
                                                               "MouthShrugUpper",
                                                               "MouthPressLeft",
                                                               "MouthPressRight",
                                                               "MouthLowerDownLeft",
                                                               "MouthLowerDownRight",
                                                               "MouthUpperUpLeft",
                                                               "MouthUpperUpRight",
                                                               "BrowDownLeft",
                                                               "BrowDownRight",
                                                               "BrowInnerUp",
                                                               "BrowOuterUpLeft",
                                                               "BrowOuterUpRight",
                                                               "CheekPuff",
                                                               "CheekSquintLeft",
                                                               "CheekSquintRight",
                                                               "NoseSneerLeft",
                                                               "NoseSneerRight",
                                                               "TongueOut"};
  return kShapes;
}

std::vector<std::string> arkit_shape_names() {
  std::vector<std::string> names;
  for (const std::string_view s : live_link_face_shapes()) {
    std::string n(s);
    n[0] = static_cast<char>(std::tolower(static_cast<unsigned char>(n[0])));
    names.push_back(std::move(n));
  }
  return names;
}

std::string live_link_timecode(int frame, double fps) {
  // Whole rates count frames exactly; others through the time.
  long long second = 0, in_second = 0;
  double sub = 0;
  if (const double whole = std::round(fps); std::abs(fps - whole) < 1e-9) {
    second = frame / static_cast<long long>(whole);
    in_second = frame % static_cast<long long>(whole);
  } else {
    const double t = frame / fps;
    second = static_cast<long long>(std::floor(t + 1e-9));
    const double f = (t - static_cast<double>(second)) * fps;
    in_second = static_cast<long long>(std::floor(f + 1e-6));
    sub = std::max(0.0, f - static_cast<double>(in_second));
  }
  char buf[48];
  std::snprintf(buf, sizeof buf, "%02lld:%02lld:%02lld:%02lld.%03d", second / 3600,
                second / 60 % 60, second % 60, in_second,
                std::min(999, static_cast<int>(std::lround(sub * 1000))));
  return buf;
}

std::string to_live_link_csv(const WeightTrack& track) {
  const auto& shapes = live_link_face_shapes();
  std::array<int, 52> column{};  // the track's shape of each column, -1: none
  for (std::size_t c = 0; c < shapes.size(); ++c) {
    column[c] = -1;
    for (std::size_t s = 0; s < track.shapes.size(); ++s)
      if (shape_key(track.shapes[s]) == shape_key(shapes[c])) column[c] = static_cast<int>(s);
  }
  std::string out = "Timecode,BlendShapeCount";
  for (const std::string_view s : shapes) (out += ',') += s;
  out +=
      ",HeadYaw,HeadPitch,HeadRoll,LeftEyeYaw,LeftEyePitch,LeftEyeRoll,RightEyeYaw,RightEyePitch,"
      "RightEyeRoll\n";
  char num[32];
  const auto put = [&](double v) {
    std::snprintf(num, sizeof num, ",%.6f", v);
    out += num;
  };
  for (int f = 0; f < track.frames; ++f) {
    out += live_link_timecode(f, track.fps);
    out += ",61";
    const auto row = track.frame(f);
    for (const int s : column) put(s < 0 ? 0.0 : row[static_cast<std::size_t>(s)]);
    const rig::BodyPose head =
        static_cast<std::size_t>(f) < track.head.size() ? track.head[f] : rig::BodyPose{};
    for (const double v : {double(head.yaw), double(head.pitch), double(head.roll)}) put(v);
    for (int k = 0; k < 6; ++k) put(0.0);
    out += '\n';
  }
  return out;
}

}  // namespace facecast::anim
