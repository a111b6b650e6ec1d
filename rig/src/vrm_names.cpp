#include "facecast/rig/vrm_names.hpp"

#include <algorithm>
#include <cctype>

namespace facecast::rig {
namespace {

bool same_ignoring_case(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) ==
                  std::tolower(static_cast<unsigned char>(y));
         });
}

}  // namespace

const std::vector<std::pair<std::string_view, std::string_view>>& vrm_presets() {
  static const std::vector<std::pair<std::string_view, std::string_view>> kPresets = {
      {"Neutral", "neutral"},
      {"A", "aa"},
      {"I", "ih"},
      {"U", "ou"},
      {"E", "ee"},
      {"O", "oh"},
      {"Blink", "blink"},
      {"Blink_L", "blinkLeft"},
      {"Blink_R", "blinkRight"},
      {"Joy", "happy"},
      {"Angry", "angry"},
      {"Sorrow", "sad"},
      {"Fun", "relaxed"},
      {"Surprised", "surprised"},
      {"LookUp", "lookUp"},
      {"LookDown", "lookDown"},
      {"LookLeft", "lookLeft"},
      {"LookRight", "lookRight"}};
  return kPresets;
}

std::string vrm1_name(std::string_view name) {
  for (const auto& [v0, v1] : vrm_presets())
    if (same_ignoring_case(name, v0)) return std::string(v1);
  return std::string(name);
}

std::string vrm0_name(std::string_view name) {
  for (const auto& [v0, v1] : vrm_presets())
    if (name == v1) return std::string(v0);
  return std::string(name);
}

}  // namespace facecast::rig
