#include "facecast/server/vmc.hpp"

#include <lo/lo.h>

#include <Eigen/Geometry>
#include <charconv>

#include "facecast/anim/live_link.hpp"
#include "facecast/core/error.hpp"
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
  lo_bundle bundle = lo_bundle_new(LO_TT_IMMEDIATE);
  const auto add = [&](const char* path, lo_message m) { lo_bundle_add_message(bundle, path, m); };
  for (std::size_t i = 0; i < shapes.size() && i < weights.size(); ++i) {
    lo_message m = lo_message_new();
    lo_message_add_string(m, impl_->wire[i].c_str());
    lo_message_add_float(m, weights[i]);
    add("/VMC/Ext/Blend/Val", m);
  }
  add("/VMC/Ext/Blend/Apply", lo_message_new());
  // Yaw about +Y, pitch about +X, roll about +Z (rig/motion.hpp), in Unity's left-handed axes
  // (z mirrored: the rotation's x and y components change sign). The neck takes a third of the
  // turn, the head the rest, as the renderer shares it.
  const Eigen::Quaternionf q = Eigen::AngleAxisf(head.yaw, Eigen::Vector3f::UnitY()) *
                               Eigen::AngleAxisf(head.pitch, Eigen::Vector3f::UnitX()) *
                               Eigen::AngleAxisf(head.roll, Eigen::Vector3f::UnitZ());
  const Eigen::Quaternionf neck = Eigen::Quaternionf::Identity().slerp(1.0f / 3.0f, q);
  const Eigen::Quaternionf rest = neck.conjugate() * q;
  for (const auto& [bone, r] : {std::pair{"Neck", neck}, std::pair{"Head", rest}}) {
    lo_message m = lo_message_new();
    lo_message_add_string(m, bone);
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
