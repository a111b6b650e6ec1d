#include "facecast/rigbuild/build_target.hpp"

#include <tiny_gltf.h>

#include "facecast/core/error.hpp"
#include "facecast/rig/rig_io.hpp"

namespace facecast::rigbuild {

BuildTarget BuildTarget::from_document(rig::AvatarDocument doc) {
  BuildTarget t;
  t.view_ = rig::make_view(doc);
  t.doc_ = std::move(doc);
  t.neutral_ = t.view_->rig;
  t.neutral_.shapes.clear();
  return t;
}

BuildTarget BuildTarget::read(const std::filesystem::path& path) {
  const std::string ext = path.extension().string();
  if (ext == ".glb" || ext == ".gltf" || ext == ".vrm")
    return from_document(rig::AvatarDocument::read(path));
  BuildTarget t;
  t.neutral_ = rig::load_rig(path);  // an OBJ, or the format error
  t.neutral_.shapes.clear();
  return t;
}

BuildTarget BuildTarget::parse(std::string_view bytes, std::string_view format,
                               std::string_view name, const rig::DecodeLimits& limits) {
  if (format == "glb" || format == "gltf" || format == "vrm")
    return from_document(rig::AvatarDocument::parse(bytes, name, limits));
  if (format != "obj")
    throw Error(std::string(name) + ": format '" + std::string(format) +
                "' is not obj, glb, gltf or vrm");
  BuildTarget t;
  t.neutral_ = rig::parse_obj(bytes, name, limits);
  t.neutral_.shapes.clear();
  return t;
}

std::string BuildTarget::glb_bytes(const rig::Rig& built) const {
  if (!doc_) return rig::glb_bytes(built);
  if (built.vertex_count() != view_->rig.vertex_count())
    throw Error("build result: " + std::to_string(built.vertex_count()) +
                    " vertices for an avatar face of " + std::to_string(view_->rig.vertex_count()),
                ErrorCode::kInternal);
  rig::AvatarDocument out = rig::AvatarDocument::from_model(doc_->model(), doc_->name());
  rig::write_back(out, *view_, built);
  return out.glb_bytes();
}

}  // namespace facecast::rigbuild
