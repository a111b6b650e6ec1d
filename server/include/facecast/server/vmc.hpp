#pragma once
// VMC out: blendshape weights and the head to desktop VTuber apps (VSeeFace, Warudo, VNyan,
// VMagicMirror) over the VMC protocol -- OSC over UDP (liblo), one bundle per frame:
// /VMC/Ext/Blend/Val (name, value) for every shape, /VMC/Ext/Blend/Apply, the head, neck and idle
// body (Spine, Chest, LeftShoulder, RightShoulder: rig::body_turns) as /VMC/Ext/Bone/Pos (name,
// position, local rotation quaternion in Unity's left-handed axes),
// /VMC/Ext/OK (1) and /VMC/Ext/T (seconds). Receivers take it on port 39539 by default.
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "facecast/rig/motion.hpp"

namespace facecast::server {

/// The names a receiver expects: Perfect Sync (the 52 ARKit names, camelCase), VRM 0.x presets
/// (A I U E O, Blink, Joy...) or VRM 1.0 presets (aa ih ou ee oh, blink, happy...).
enum class VmcNames { kPerfectSync, kVrm0, kVrm1 };
/// "perfect-sync" | "vrm0" | "vrm1"; throws Error naming `field` otherwise.
VmcNames parse_vmc_names(std::string_view text, std::string_view field = "vmc names");

/// The shapes to animate for a receiver of `names` (the animation's mapping takes them): the ARKit
/// names, or the VRM 1.0 presets (VRM 0.x names are sent under their own spelling).
std::vector<std::string> vmc_shape_names(VmcNames names);

/// "HOST:PORT" (a name or an IPv4/IPv6 address; [v6]:port), checked; throws Error naming `field`.
struct VmcTarget {
  std::string host;
  int port = 39539;
};
VmcTarget parse_vmc_target(std::string_view text, std::string_view field = "vmc");

class VmcSender {
 public:
  /// Resolves the target once; throws Error naming it when it cannot.
  VmcSender(const VmcTarget& target, VmcNames names);
  ~VmcSender();
  VmcSender(const VmcSender&) = delete;
  VmcSender& operator=(const VmcSender&) = delete;

  /// One frame: `weights[i]` of `shapes[i]` (as vmc_shape_names gave them), the head pose, and
  /// the time since the start. Throws Error when the datagram cannot be sent.
  void send(std::span<const std::string> shapes, std::span<const float> weights,
            const rig::BodyPose& head, double t);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace facecast::server
