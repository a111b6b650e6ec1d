#pragma once
// VRM expression presets under their two names: VRM 0.x (A, Blink_L, Joy, ... as VSeeFace and other
// VMC receivers of VRM 0.x models expect them) and VRM 1.0 (aa, blinkLeft, happy, ...), which is
// what Facecast's tables use (configs/anim/visemes_vrm.json).
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace facecast::rig {

/// (VRM 0.x name, VRM 1.0 name) of every preset both versions have.
const std::vector<std::pair<std::string_view, std::string_view>>& vrm_presets();

/// The VRM 1.0 name of a VRM 0.x preset, matched without regard to case ("joy" -> "happy");
/// `name` itself when it is none.
std::string vrm1_name(std::string_view name);
/// The VRM 0.x name of a VRM 1.0 preset ("happy" -> "Joy"); `name` itself when it is none.
std::string vrm0_name(std::string_view name);

}  // namespace facecast::rig
