// KHR_draco_mesh_compression: a primitive's indices and attributes decoded with libdraco, converted
// to the component types its accessors declare.
#include <draco/compression/decode.h>
#include <draco/mesh/mesh.h>

#include <cstring>

#include "facecast/core/error.hpp"
#include "gltf_package.hpp"

namespace facecast::anim::detail {
namespace {

template <typename T>
void convert(const draco::PointAttribute& att, const draco::Mesh& mesh, DracoRequest& r,
             const std::string& what) {
  const std::size_t row = sizeof(T) * static_cast<std::size_t>(r.components);
  r.out.assign(r.count * row, '\0');
  T values[16];
  for (std::size_t i = 0; i < r.count; ++i) {
    const auto avi = att.mapped_index(draco::PointIndex(static_cast<std::uint32_t>(i)));
    if (avi.value() >= att.size() ||
        !att.ConvertValue<T>(avi, static_cast<std::int8_t>(r.components), values))
      throw Error(what + ": Draco attribute " + std::to_string(r.unique_id) + " cannot be read");
    std::memcpy(r.out.data() + i * row, values, row);
  }
  (void)mesh;
}

}  // namespace

void decode_draco(std::string_view bytes, std::size_t index_count, std::string& indices,
                  std::vector<DracoRequest>& attributes, const std::string& what) {
  draco::DecoderBuffer buffer;
  buffer.Init(bytes.data(), bytes.size());
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok())
    throw Error(what + ": Draco data cannot be decoded: " + decoded.status().error_msg_string());
  const std::unique_ptr<draco::Mesh> mesh = std::move(decoded).value();
  const std::size_t faces = mesh->num_faces();
  if (index_count != faces * 3)
    throw Error(what + ": Draco mesh has " + std::to_string(faces * 3) + " indices, the accessor " +
                std::to_string(index_count));
  indices.assign(faces * 3 * sizeof(std::uint32_t), '\0');
  for (draco::FaceIndex f(0); f < mesh->num_faces(); ++f) {
    const auto& face = mesh->face(f);
    for (int c = 0; c < 3; ++c) {
      const std::uint32_t v = face[c].value();
      if (v >= mesh->num_points()) throw Error(what + ": Draco face index out of range");
      std::memcpy(indices.data() + (f.value() * 3 + c) * 4, &v, 4);
    }
  }
  for (auto& r : attributes) {
    const draco::PointAttribute* att = mesh->GetAttributeByUniqueId(r.unique_id);
    if (!att)
      throw Error(what + ": Draco attribute " + std::to_string(r.unique_id) + " is missing");
    if (r.count != mesh->num_points())
      throw Error(what + ": Draco mesh has " + std::to_string(mesh->num_points()) +
                  " points, the accessor " + std::to_string(r.count));
    if (r.components < 1 || r.components > 16) throw Error(what + ": bad accessor type");
    switch (r.component_type) {
      case 5120:
        convert<std::int8_t>(*att, *mesh, r, what);
        break;
      case 5121:
        convert<std::uint8_t>(*att, *mesh, r, what);
        break;
      case 5122:
        convert<std::int16_t>(*att, *mesh, r, what);
        break;
      case 5123:
        convert<std::uint16_t>(*att, *mesh, r, what);
        break;
      case 5125:
        convert<std::uint32_t>(*att, *mesh, r, what);
        break;
      case 5126:
        convert<float>(*att, *mesh, r, what);
        break;
      default:
        throw Error(what + ": bad component type for a Draco attribute");
    }
  }
}

}  // namespace facecast::anim::detail
