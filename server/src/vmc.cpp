#include "facecast/server/vmc.hpp"

#include <lo/lo.h>

#include <Eigen/Geometry>
#include <charconv>

#include "facecast/anim/live_link.hpp"
#include "facecast/core/error.hpp"
#include "facecast/rig/body.hpp"
#include "facecast/rig/vrm_names.hpp"

namespace facecast::server {

VmcNames parse_vmc_names(std::string_view text, std::string_view field) {
  if (text == "perfect-sync") return VmcNames::kPerfectSync;
  if (text == "vrm0") return VmcNames::kVrm0;
  if (text == "vrm1") return VmcNames::kVrm1;
  throw Error(std::string(field) + ": '" + std::string(text) +
              "' is not perfect-sync, vrm0 or vrm1");
}

std::vector<std::string> vmc_shape_names(VmcNames names) {
  if (names == VmcNames::kPerfectSync) return anim::arkit_shape_names();
  std::vector<std::string> out;
  for (const auto& [v0, v1] : rig::vrm_presets()) out.emplace_back(v1);
  return out;
}

VmcTarget parse_vmc_target(std::string_view text, std::string_view field) {
  const auto bad = [&](const std::string& why) {
    return Error(std::string(field) + ": '" + std::string(text) + "' " + why);
  };
  const std::size_t colon = text.rfind(':');
  if (colon == std::string_view::npos || colon == 0) throw bad("is not HOST:PORT");
  std::string_view host = text.substr(0, colon), port = text.substr(colon + 1);
  if (host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  VmcTarget t;
  t.host = std::string(host);
  const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), t.port);
  if (ec != std::errc() || end != port.data() + port.size() || t.port < 1 || t.port > 65535)
    throw bad("has no port between 1 and 65535");
  if (t.host.empty() || t.host.size() > 253) throw bad("has no host");
  return t;
}

namespace {

// A humanoid in Unity's bone names, standing with its arms down, its bones unturned at rest: the
// bones VMC carries for the body. Its upper arms are left out: a receiver's arms at rest are not
// unturned (T-pose), so a shrug raises the shoulders with the arms on them.
struct VmcBody {
  rig::Skeleton skeleton;
  rig::BodyJoints joints;
};

const VmcBody& vmc_body() {
  static const VmcBody body = [] {
    VmcBody b;
    rig::Skeleton& s = b.skeleton;
    s.joint_names = {"Hips", "Spine", "Chest", "Neck", "Head", "LeftShoulder", "RightShoulder"};
    s.parent = {-1, 0, 1, 2, 3, 2, 2};
    s.rest_origin = {{0, 1.0f, 0}, {0, 1.1f, 0},      {0, 1.3f, 0},      {0, 1.5f, 0},
                     {0, 1.6f, 0}, {0.05f, 1.45f, 0}, {-0.05f, 1.45f, 0}};
    s.humanoid = {{"hips", 0}, {"spine", 1},        {"chest", 2},        {"neck", 3},
                  {"head", 4}, {"leftShoulder", 5}, {"rightShoulder", 6}};
    b.joints = rig::find_body_joints(s);
    return b;
  }();
  return body;
}

}  // namespace

struct VmcSender::Impl {
  lo_address address = nullptr;
  VmcNames names = VmcNames::kPerfectSync;
  std::vector<std::string> wire;  // the names as sent, cached per shape list
  std::vector<std::string> for_shapes;
};

VmcSender::VmcSender(const VmcTarget& target, VmcNames names) : impl_(std::make_unique<Impl>()) {
  impl_->names = names;
  const std::string port = std::to_string(target.port);
  impl_->address = lo_address_new_with_proto(LO_UDP, target.host.c_str(), port.c_str());
  if (!impl_->address) throw Error("vmc: cannot resolve '" + target.host + "'");
}

VmcSender::~VmcSender() {
  if (impl_->address) lo_address_free(impl_->address);
}

void VmcSender::send(std::span<const std::string> shapes, std::span<const float> weights,
                     const rig::BodyPose& head, double t) {
  if (impl_->for_shapes.size() != shapes.size() ||
      !std::equal(shapes.begin(), shapes.end(), impl_->for_shapes.begin())) {
    impl_->for_shapes.assign(shapes.begin(), shapes.end());
    impl_->wire.clear();
    for (const auto& s : shapes)
      impl_->wire.push_back(impl_->names == VmcNames::kVrm0 ? rig::vrm0_name(s) : s);
  }
  // LO_TT_IMMEDIATE without the macro's C99 compound literal (clang refuses it in C++).
  lo_bundle bundle = lo_bundle_new(lo_timetag{0U, 1U});
  const auto add = [&](const char* path, lo_message m) { lo_bundle_add_message(bundle, path, m); };
  for (std::size_t i = 0; i < shapes.size() && i < weights.size(); ++i) {
    lo_message m = lo_message_new();
    lo_message_add_string(m, impl_->wire[i].c_str());
    lo_message_add_float(m, weights[i]);
    add("/VMC/Ext/Blend/Val", m);
  }
  add("/VMC/Ext/Blend/Apply", lo_message_new());
  // The head and the idle body as the renderer turns them (rig::body_turns), on a humanoid
  // whose bones rest unturned, as a receiver's normalized humanoid does; in Unity's left-handed
  // axes (z mirrored: a rotation's x and y components change sign).
  for (const auto& [joint, r] : rig::body_turns(vmc_body().joints, vmc_body().skeleton, head)) {
    lo_message m = lo_message_new();
    lo_message_add_string(m,
                          vmc_body().skeleton.joint_names[static_cast<std::size_t>(joint)].c_str());
    for (int k = 0; k < 3; ++k) lo_message_add_float(m, 0.0f);
    lo_message_add_float(m, -r.x());
    lo_message_add_float(m, -r.y());
    lo_message_add_float(m, r.z());
    lo_message_add_float(m, r.w());
    add("/VMC/Ext/Bone/Pos", m);
  }
  lo_message ok = lo_message_new();
  lo_message_add_int32(ok, 1);
  add("/VMC/Ext/OK", ok);
  lo_message time = lo_message_new();
  lo_message_add_float(time, static_cast<float>(t));
  add("/VMC/Ext/T", time);
  const int sent = lo_send_bundle(impl_->address, bundle);
  lo_bundle_free_recursive(bundle);
  if (sent < 0)
    throw Error(std::string("vmc: sending failed: ") + lo_address_errstr(impl_->address),
                ErrorCode::kInternal);
}

}  // namespace facecast::server
