// KHR_draco_mesh_compression: a primitive's indices and attributes decoded with libdraco, converted
// to the component types its accessors declare.
#include <draco/compression/decode.h>
#include <draco/mesh/mesh.h>

#include <cstring>

#include "facecast/core/error.hpp"
#include "gltf_package.hpp"

namespace facecast::rig::detail {
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

// A reader of the Draco bitstream's header fields (little-endian integers, LEB128 varints).
class DracoReader {
 public:
  DracoReader(std::string_view b, const std::string& what) : b_(b), what_(what) {}

  std::uint32_t u8() {
    need(1);
    return static_cast<unsigned char>(b_[at_++]);
  }
  std::uint32_t u16() {
    const std::uint32_t lo = u8();
    return lo | u8() << 8;
  }
  std::uint32_t u32() {
    const std::uint32_t lo = u16();
    return lo | u16() << 16;
  }
  std::uint32_t varint() {
    std::uint64_t v = 0;
    for (int shift = 0; shift < 35; shift += 7) {
      const std::uint32_t byte = u8();
      v |= static_cast<std::uint64_t>(byte & 0x7F) << shift;
      if (!(byte & 0x80)) {
        if (v > 0xFFFFFFFFu) break;
        return static_cast<std::uint32_t>(v);
      }
    }
    fail("has a malformed number");
  }
  void skip(std::size_t n) {
    need(n);
    at_ += n;
  }
  std::size_t remaining() const { return b_.size() - at_; }
  [[noreturn]] void fail(const char* why) const {
    throw Error(what_ + ": Draco header " + why + " (at byte " + std::to_string(at_) + ")");
  }

 private:
  void need(std::size_t n) const {
    if (n > b_.size() - at_) fail("is truncated");
  }
  std::string_view b_;
  const std::string& what_;
  std::size_t at_ = 0;
};

// One metadata (entries, then nested sub-metadata, each with a name), skipped without recursion:
// every piece costs at least a byte, so the loop ends within the stream.
void skip_metadata(DracoReader& r) {
  std::size_t pending = 1;
  for (bool top = true; pending > 0; top = false) {
    --pending;
    if (!top) r.skip(r.u8());  // a sub-metadata's name
    const std::uint32_t entries = r.varint();
    if (entries > r.remaining()) r.fail("declares more metadata entries than it holds");
    for (std::uint32_t e = 0; e < entries; ++e) {
      r.skip(r.u8());      // name
      r.skip(r.varint());  // value
    }
    const std::uint32_t subs = r.varint();
    if (subs > r.remaining()) r.fail("declares more sub-metadata than it holds");
    pending += subs;
  }
}

// Geometry metadata: per attribute (unique id, metadata), then the geometry's.
void skip_geometry_metadata(DracoReader& r) {
  const std::uint32_t attributes = r.varint();
  if (attributes > r.remaining()) r.fail("declares more metadata than it holds");
  for (std::uint32_t a = 0; a < attributes; ++a) {
    (void)r.varint();
    skip_metadata(r);
  }
  skip_metadata(r);
}

}  // namespace

DracoCounts draco_counts(std::string_view bytes, const std::string& what) {
  DracoReader r(bytes, what);
  if (bytes.size() < 5 || bytes.substr(0, 5) != "DRACO") r.fail("has no DRACO signature");
  r.skip(5);
  const std::uint32_t major = r.u8(), minor = r.u8();
  const std::uint32_t version = major << 8 | minor;
  if (major < 1 || major > 2 || (major == 2 && minor > 2)) r.fail("has an unknown version");
  if (r.u8() != 1) r.fail("is not a triangle mesh");
  const std::uint32_t method = r.u8();
  const std::uint32_t flags = r.u16();
  if (version >= 0x0103 && (flags & 0x8000)) skip_geometry_metadata(r);
  const auto number = [&](std::uint32_t varint_from) {
    return version < varint_from ? r.u32() : r.varint();
  };
  DracoCounts c;
  if (method == 0) {  // sequential
    c.sequential = true;
    c.faces = number(0x0202);
    c.points = number(0x0202);
    return c;
  }
  if (method != 1) r.fail("has an unknown encoding method");
  (void)r.u8();                                // the traversal decoder
  if (version < 0x0202) (void)number(0x0200);  // new vertices (older streams)
  const std::size_t vertices = number(0x0200);
  c.faces = number(0x0200);
  (void)r.u8();  // attribute data
  const std::size_t symbols = number(0x0200), splits = number(0x0200);
  if (symbols > c.faces || splits > symbols) r.fail("declares more symbols than faces");
  // The corner table holds the encoded vertices and one more per split symbol; a vertex belongs
  // to a face.
  c.points = vertices + splits;
  if (c.points > 3 * c.faces + 3)
    r.fail(("declares " + std::to_string(c.points) + " vertices for " + std::to_string(c.faces) +
            " faces")
               .c_str());
  return c;
}

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

}  // namespace facecast::rig::detail
