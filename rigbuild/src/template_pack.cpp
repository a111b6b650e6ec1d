// The shipped template's compact GLB (template.hpp): KHR_mesh_quantization +
// EXT_meshopt_compression written directly (glTF JSON and the GLB container), and the loaders of
// the shipped file.
#include <meshoptimizer.h>
#include <tiny_gltf.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <nlohmann/json.hpp>

#include "facecast/core/error.hpp"
#include "facecast/core/install.hpp"
#include "facecast/rig/avatar_document.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/rigbuild/template.hpp"

namespace facecast::rigbuild {
namespace {

using nlohmann::json;

constexpr int kShort = 5122, kByte = 5120, kUShort = 5123, kUInt = 5125, kFloat = 5126;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;
constexpr float kUvSteps = 4096.0f;  // texture coordinates are rounded to 1/kUvSteps

void pad4(std::string& s) {
  while (s.size() % 4) s.push_back('\0');
}

// Views written compressed into `bin` (the GLB chunk) and declared over a fallback buffer that
// the decoder fills (buffer 1, no data).
struct Packer {
  std::string bin;
  std::size_t fallback = 0;
  json views = json::array(), accessors = json::array();

  int view(const void* data, std::size_t count, std::size_t stride, bool triangles, int target) {
    std::vector<unsigned char> out;
    std::size_t size = 0;
    if (triangles) {
      out.resize(meshopt_encodeIndexBufferBound(count, count));
      size = meshopt_encodeIndexBuffer(out.data(), out.size(),
                                       static_cast<const unsigned int*>(data), count);
    } else {
      out.resize(meshopt_encodeVertexBufferBound(count, stride));
      size = meshopt_encodeVertexBuffer(out.data(), out.size(), data, count, stride);
    }
    if (size == 0) throw Error("template GLB: meshopt could not encode a buffer view");
    pad4(bin);
    const std::size_t at = bin.size();
    bin.append(reinterpret_cast<const char*>(out.data()), size);
    const std::size_t stored = stride * count;  // indices: 2 or 4 bytes each
    json ext = {{"buffer", 0},        {"byteOffset", at},
                {"byteLength", size}, {"byteStride", stride},
                {"count", count},     {"mode", triangles ? "TRIANGLES" : "ATTRIBUTES"}};
    json v = {{"buffer", 1},
              {"byteOffset", fallback},
              {"byteLength", stored},
              {"target", target},
              {"extensions", {{"EXT_meshopt_compression", ext}}}};
    if (!triangles) v["byteStride"] = stride;
    fallback += (stored + 3) / 4 * 4;
    views.push_back(v);
    return static_cast<int>(views.size()) - 1;
  }

  int accessor(int view, int component, bool normalized, std::size_t count, const char* type,
               json min = nullptr, json max = nullptr) {
    json a = {{"bufferView", view}, {"componentType", component}, {"count", count}, {"type", type}};
    if (normalized) a["normalized"] = true;
    if (!min.is_null()) a["min"] = std::move(min), a["max"] = std::move(max);
    accessors.push_back(a);
    return static_cast<int>(accessors.size()) - 1;
  }

  // #rows by 3 values quantized to normalized int16 (value / scale), stride 8, with min/max (the
  // stored integers, as glTF asks of normalized accessors).
  int vec3_short(const Eigen::Matrix<double, Eigen::Dynamic, 3>& v, double scale) {
    std::vector<std::int16_t> q(static_cast<std::size_t>(v.rows()) * 4, 0);
    Eigen::Vector3i lo = Eigen::Vector3i::Constant(32767), hi = Eigen::Vector3i::Constant(-32767);
    for (Eigen::Index r = 0; r < v.rows(); ++r)
      for (int c = 0; c < 3; ++c) {
        const auto s = static_cast<std::int16_t>(std::lround(v(r, c) / scale * 32767.0));
        q[static_cast<std::size_t>(r) * 4 + static_cast<std::size_t>(c)] = s;
        lo[c] = std::min<int>(lo[c], s);
        hi[c] = std::max<int>(hi[c], s);
      }
    if (v.rows() == 0) lo.setZero(), hi.setZero();
    const int vw = view(q.data(), static_cast<std::size_t>(v.rows()), 8, false, kArrayBuffer);
    return accessor(vw, kShort, true, static_cast<std::size_t>(v.rows()), "VEC3",
                    {lo[0], lo[1], lo[2]}, {hi[0], hi[1], hi[2]});
  }
};

json material_json(const rig::Material& m) {
  json j = {
      {"name", m.name},
      {"pbrMetallicRoughness",
       {{"baseColorFactor", {m.base_color[0], m.base_color[1], m.base_color[2], m.base_color[3]}},
        {"metallicFactor", m.metallic},
        {"roughnessFactor", m.roughness}}}};
  if (m.double_sided) j["doubleSided"] = true;
  if (m.base_color[3] < 1.0f) j["alphaMode"] = "BLEND";
  return j;
}

// The GLB container: header, JSON chunk (space-padded), BIN chunk (zero-padded).
std::string glb_container(const json& doc, std::string bin) {
  std::string text = doc.dump();
  while (text.size() % 4) text.push_back(' ');
  pad4(bin);
  const auto u32 = [](std::string& s, std::uint32_t v) {
    char b[4];
    std::memcpy(b, &v, 4);
    s.append(b, 4);
  };
  std::string out;
  u32(out, 0x46546C67u);  // "glTF"
  u32(out, 2);
  u32(out, static_cast<std::uint32_t>(12 + 8 + text.size() + 8 + bin.size()));
  u32(out, static_cast<std::uint32_t>(text.size()));
  u32(out, 0x4E4F534Au);  // "JSON"
  out += text;
  u32(out, static_cast<std::uint32_t>(bin.size()));
  u32(out, 0x004E4942u);  // "BIN"
  out += bin;
  return out;
}

// The identity modes as int16 accessors that no primitive uses (template.hpp says why), each
// [{name, accessor}] of mesh.extras.facecast.identity.
json identity_accessors(Packer& p, const std::vector<rig::Positions>& identity, int nv,
                        double scale) {
  json out = json::array();
  for (std::size_t k = 0; k < identity.size(); ++k) {
    char name[32];
    std::snprintf(name, sizeof name, "identity%03zu", k);
    const rig::Positions& d = identity[k];
    if (d.rows() != nv || d.cols() != 3)
      throw Error(std::string("template GLB: ") + name + " has " + std::to_string(d.rows()) +
                  " rows, the rig " + std::to_string(nv) + " vertices");
    if (d.size() && d.cwiseAbs().maxCoeff() > scale)
      throw Error(std::string("template GLB: ") + name + " moves a vertex by " +
                  std::to_string(d.cwiseAbs().maxCoeff()) + ", outside the quantization's range " +
                  std::to_string(scale));
    out.push_back({{"name", name}, {"accessor", p.vec3_short(d.cast<double>(), scale)}});
  }
  return out;
}

}  // namespace

double quantization_step(const rig::Rig& rig) {
  const Eigen::RowVector3f lo = rig.positions.colwise().minCoeff();
  const Eigen::RowVector3f hi = rig.positions.colwise().maxCoeff();
  double range = 0.5 * static_cast<double>((hi - lo).maxCoeff());
  for (const auto& s : rig.shapes)
    if (s.deltas.size())
      range = std::max(range, static_cast<double>(s.deltas.cwiseAbs().maxCoeff()));
  // 14 bits over the box (gltfpack's default for positions; 21 um on the FaceKit's 34 cm): the
  // int16's two top bits stay unused, which makes the byte deltas meshopt codes smaller.
  return 0.5 * range / 8191.0;
}

std::string compact_glb_bytes(const rig::Rig& rig, const std::vector<rig::Positions>& identity) {
  rig.validate("template");
  const int nv = rig.vertex_count();
  const Eigen::RowVector3d lo = rig.positions.colwise().minCoeff().cast<double>();
  const Eigen::RowVector3d hi = rig.positions.colwise().maxCoeff().cast<double>();
  const Eigen::RowVector3d centre = 0.5 * (lo + hi);
  const double scale = 2.0 * 32767.0 * quantization_step(rig);
  Packer p;
  json attributes;
  const Eigen::Matrix<double, Eigen::Dynamic, 3> centred =
      rig::to_points(rig.positions).rowwise() - centre;
  attributes["POSITION"] = p.vec3_short(centred, scale);
  std::vector<std::int8_t> normals(static_cast<std::size_t>(nv) * 4, 0);
  for (int v = 0; v < nv; ++v)
    for (int c = 0; c < 3; ++c)
      normals[static_cast<std::size_t>(v) * 4 + static_cast<std::size_t>(c)] =
          static_cast<std::int8_t>(std::lround(rig.normals(v, c) * 127.0f));
  attributes["NORMAL"] =
      p.accessor(p.view(normals.data(), static_cast<std::size_t>(nv), 4, false, kArrayBuffer),
                 kByte, true, static_cast<std::size_t>(nv), "VEC3");
  if (rig.uvs.rows() == nv) {
    // As the rig holds them (the tree's GLB writer and reader do not flip v either), rounded to
    // 1/4096 so the floats' low mantissa bytes are zero and compress to nothing.
    const rig::UVs uv = (rig.uvs.array() * kUvSteps).round() / kUvSteps;
    attributes["TEXCOORD_0"] =
        p.accessor(p.view(uv.data(), static_cast<std::size_t>(nv), 8, false, kArrayBuffer), kFloat,
                   false, static_cast<std::size_t>(nv), "VEC2");
  }
  json targets = json::array(), names = json::array(), weights = json::array();
  for (const auto& s : rig.shapes) {
    const rig::Positions d = s.dense(nv);
    targets.push_back({{"POSITION", p.vec3_short(d.cast<double>(), scale)}});
    names.push_back(s.name);
    weights.push_back(0);
  }
  const bool short_indices = nv <= 65535;
  json primitives = json::array();
  for (std::size_t m = 0; m < rig.materials.size(); ++m) {
    std::vector<unsigned int> idx;
    for (int f = 0; f < rig.triangle_count(); ++f)
      if (rig.triangle_material[static_cast<std::size_t>(f)] == static_cast<int>(m))
        for (int k = 0; k < 3; ++k) idx.push_back(static_cast<unsigned int>(rig.triangles(f, k)));
    if (idx.empty()) continue;
    meshopt_optimizeVertexCache(idx.data(), idx.data(), idx.size(), static_cast<std::size_t>(nv));
    const int view =
        p.view(idx.data(), idx.size(), short_indices ? 2 : 4, true, kElementArrayBuffer);
    primitives.push_back({{"attributes", attributes},
                          {"indices", p.accessor(view, short_indices ? kUShort : kUInt, false,
                                                 idx.size(), "SCALAR")},
                          {"material", m},
                          {"targets", targets}});
  }
  json landmarks = json::array();
  for (const auto& l : rig.landmarks) landmarks.push_back({{"name", l.name}, {"vertex", l.vertex}});
  json facecast_extras = {{"landmarks", landmarks}};
  if (!identity.empty()) facecast_extras["identity"] = identity_accessors(p, identity, nv, scale);
  json materials = json::array();
  for (const auto& m : rig.materials) materials.push_back(material_json(m));
  const std::vector<std::string> ext = {"KHR_mesh_quantization", "EXT_meshopt_compression"};
  pad4(p.bin);
  const json doc = {{"asset", {{"version", "2.0"}, {"generator", "facecast rig pack-template"}}},
                    {"extensionsUsed", ext},
                    {"extensionsRequired", ext},
                    {"scene", 0},
                    {"scenes", {{{"nodes", {0}}}}},
                    {"nodes",
                     {{{"name", "Head"},
                       {"mesh", 0},
                       {"translation", {centre[0], centre[1], centre[2]}},
                       {"scale", {scale, scale, scale}}}}},
                    {"meshes",
                     {{{"name", "Head"},
                       {"primitives", primitives},
                       {"weights", weights},
                       {"extras", {{"targetNames", names}, {"facecast", facecast_extras}}}}}},
                    {"materials", materials},
                    {"accessors", p.accessors},
                    {"bufferViews", p.views},
                    {"buffers",
                     {{{"byteLength", p.bin.size()}},
                      {{"byteLength", p.fallback},
                       {"extensions", {{"EXT_meshopt_compression", {{"fallback", true}}}}}}}}};
  return glb_container(doc, std::move(p.bin));
}

std::filesystem::path shipped_template_path() {
  const auto share = installed_share_dir();
  const std::filesystem::path path =
      share.empty() ? std::filesystem::path(FACECAST_SHIPPED_TEMPLATE) : share / "ict_facekit.glb";
  if (!std::filesystem::exists(path))
    throw Error(
        path.string() +
            ": the shipped template is missing (rigbuild/data/ict_facekit.glb of the source tree, "
            "installed into share/facecast); give --template",
        ErrorCode::kNotFound);
  return path;
}

rig::Rig load_shipped_template() {
  return rig::read_glb(shipped_template_path());
}

TemplateSummary shipped_template_summary() {
  const auto path = shipped_template_path();
  const rig::AvatarDocument doc = rig::AvatarDocument::read(path);
  const tinygltf::Model& m = doc.model();
  if (m.meshes.empty() || m.meshes[0].primitives.empty())
    throw Error(path.string() + ": meshes[0] has no primitives");
  const tinygltf::Mesh& mesh = m.meshes[0];
  const tinygltf::Value& names = mesh.extras.Get("targetNames");
  if (!names.IsArray()) throw Error(path.string() + ": meshes[0].extras.targetNames is missing");
  TemplateSummary s;
  for (std::size_t i = 0; i < names.ArrayLen(); ++i)
    s.shapes.push_back(names.Get(static_cast<int>(i)).Get<std::string>());
  const auto& attributes = mesh.primitives[0].attributes;
  const auto position = attributes.find("POSITION");
  if (position == attributes.end() || position->second < 0 ||
      static_cast<std::size_t>(position->second) >= m.accessors.size())
    throw Error(path.string() + ": meshes[0].primitives[0] has no POSITION accessor");
  s.vertices = static_cast<int>(m.accessors[static_cast<std::size_t>(position->second)].count);
  return s;
}

std::vector<rig::Positions> read_template_identity(const std::filesystem::path& path) {
  return read_template_identity(rig::AvatarDocument::read(path));
}

std::vector<rig::Positions> read_template_identity(const rig::AvatarDocument& doc) {
  // The document decoded the meshopt views on load; the modes' accessors are read from them.
  const tinygltf::Model& m = doc.model();
  std::vector<rig::Positions> modes;
  if (m.meshes.empty()) return modes;
  const tinygltf::Value& list = m.meshes[0].extras.Get("facecast").Get("identity");
  if (!list.IsArray()) return modes;
  const std::string at = doc.name() + ": meshes[0].extras.facecast.identity";
  if (m.nodes.empty() || m.nodes[0].scale.size() != 3) throw Error(at + ": node 0 has no scale");
  const double scale = m.nodes[0].scale[0];
  for (std::size_t k = 0; k < list.ArrayLen(); ++k) {
    const std::string where = at + "[" + std::to_string(k) + "]";
    const tinygltf::Value& index = list.Get(static_cast<int>(k)).Get("accessor");
    if (!index.IsInt() || index.Get<int>() < 0 ||
        static_cast<std::size_t>(index.Get<int>()) >= m.accessors.size())
      throw Error(where + ": no such accessor");
    const tinygltf::Accessor& a = m.accessors[static_cast<std::size_t>(index.Get<int>())];
    if (a.componentType != kShort || a.type != TINYGLTF_TYPE_VEC3 || a.bufferView < 0 ||
        static_cast<std::size_t>(a.bufferView) >= m.bufferViews.size())
      throw Error(where + ": not an int16 VEC3 accessor");
    const tinygltf::BufferView& v = m.bufferViews[static_cast<std::size_t>(a.bufferView)];
    const std::size_t stride = v.byteStride ? v.byteStride : 6;
    if (v.buffer < 0 || static_cast<std::size_t>(v.buffer) >= m.buffers.size() || stride < 6 ||
        a.count == 0 ||
        v.byteOffset + a.byteOffset + (a.count - 1) * stride + 6 >
            m.buffers[static_cast<std::size_t>(v.buffer)].data.size())
      throw Error(where + ": its data runs past its buffer");
    const unsigned char* data =
        m.buffers[static_cast<std::size_t>(v.buffer)].data.data() + v.byteOffset + a.byteOffset;
    rig::Positions d(static_cast<Eigen::Index>(a.count), 3);
    for (std::size_t i = 0; i < a.count; ++i) {
      std::int16_t q[3];
      std::memcpy(q, data + i * stride, sizeof q);
      for (int c = 0; c < 3; ++c)
        d(static_cast<Eigen::Index>(i), c) = static_cast<float>(q[c] / 32767.0 * scale);
    }
    modes.push_back(std::move(d));
  }
  return modes;
}

}  // namespace facecast::rigbuild
