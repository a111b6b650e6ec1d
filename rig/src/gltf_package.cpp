// Packing a glTF container into one self-contained GLB (see gltf_package.hpp). Every offset and
// length the JSON declares is checked against the bytes at hand before anything is read; the JSON's
// nesting and size, the counts of glTF objects, image headers and every decoded size are checked
// against the DecodeLimits before a parser, decoder or allocation spends them.
#include "gltf_package.hpp"

#include "gltf_container.hpp"

#include <meshoptimizer.h>

#include <array>
#include <cctype>
#include <cstring>
#include <map>
#include <nlohmann/json.hpp>
#include <vector>

#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/core/json_limits.hpp"

namespace facecast::rig::detail {
namespace {

using nlohmann::json;

constexpr std::array kSupportedRequired = {
    "KHR_mesh_quantization",           "KHR_texture_transform",      "EXT_meshopt_compression",
    "KHR_meshopt_compression",         "KHR_draco_mesh_compression", "KHR_materials_unlit",
    "KHR_materials_emissive_strength", "EXT_texture_webp",
};
// The two names of meshopt compression: the vendor extension and its ratified successor (same
// fields; a stream in a newer codec version than the library's fails to decode, with an error).
constexpr std::array kMeshopt = {"EXT_meshopt_compression", "KHR_meshopt_compression"};

std::size_t size_field(const json& o, const char* key, const std::string& what,
                       std::size_t fallback = 0) {
  if (!o.contains(key)) return fallback;
  const json& v = o[key];
  if (!v.is_number_integer() || v.get<std::int64_t>() < 0)
    throw Error(what + ": '" + key + "' is not an unsigned integer");
  return v.get<std::size_t>();
}

std::string base64_decode(std::string_view in, const std::string& what) {
  std::string out;
  out.reserve(in.size() / 4 * 3);
  unsigned acc = 0;
  int bits = 0;
  for (const char ch : in) {
    int v;
    if (ch >= 'A' && ch <= 'Z')
      v = ch - 'A';
    else if (ch >= 'a' && ch <= 'z')
      v = ch - 'a' + 26;
    else if (ch >= '0' && ch <= '9')
      v = ch - '0' + 52;
    else if (ch == '+' || ch == '-')
      v = 62;
    else if (ch == '/' || ch == '_')
      v = 63;
    else if (ch == '=')
      break;
    else
      throw Error(what + ": invalid base64 in a data: URI");
    acc = (acc << 6) | static_cast<unsigned>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<char>((acc >> bits) & 0xFF));
    }
  }
  return out;
}

std::string percent_decode(const std::string& uri) {
  std::string out;
  for (std::size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] == '%' && i + 2 < uri.size() &&
        std::isxdigit(static_cast<unsigned char>(uri[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(uri[i + 2]))) {
      out.push_back(static_cast<char>(std::stoi(uri.substr(i + 1, 2), nullptr, 16)));
      i += 2;
    } else {
      out.push_back(uri[i]);
    }
  }
  return out;
}

// The bytes a URI names, and the MIME type a data: URI declares.
std::string read_uri(const std::string& uri, const std::string& what,
                     const std::optional<std::filesystem::path>& base_dir, std::string* mime) {
  if (uri.starts_with("data:")) {
    const auto comma = uri.find(',');
    const std::string header = uri.substr(5, comma == std::string::npos ? 0 : comma - 5);
    if (comma == std::string::npos || !header.ends_with(";base64"))
      throw Error(what + ": only base64 data: URIs are supported");
    if (mime) *mime = header.substr(0, header.size() - 7);
    return base64_decode(std::string_view(uri).substr(comma + 1), what);
  }
  if (!base_dir) throw Error(what + ": external file '" + uri + "' is not read from an upload");
  const std::filesystem::path rel(percent_decode(uri));
  if (rel.is_absolute() || uri.find("://") != std::string::npos)
    throw Error(what + ": external file '" + uri + "' must be a relative path");
  return read_file(*base_dir / rel);
}

bool remove_extension(json& o, const char* name) {
  if (!o.is_object() || !o.contains("extensions") || !o["extensions"].is_object()) return false;
  const bool had = o["extensions"].erase(name) > 0;
  if (o["extensions"].empty()) o.erase("extensions");
  return had;
}

void drop_from_lists(json& doc, const char* name) {
  for (const char* list : {"extensionsUsed", "extensionsRequired"}) {
    if (!doc.contains(list) || !doc[list].is_array()) continue;
    json kept = json::array();
    for (const auto& e : doc[list])
      if (!(e.is_string() && e.get<std::string>() == name)) kept.push_back(e);
    if (kept.empty())
      doc.erase(list);
    else
      doc[list] = kept;
  }
}

class Packer {
 public:
  Packer(Container c, const std::string& what, const std::optional<std::filesystem::path>& dir,
         DecodeBudget& budget)
      : c_(std::move(c)), what_(what), dir_(dir), budget_(budget) {}

  std::string run(std::string_view original) {
    check_required();
    load_buffers();
    decode_meshopt();
    decode_draco_primitives();
    pack_images();
    if (!changed_ && c_.glb) return std::string(original);
    return assemble();
  }

 private:
  const DecodeLimits& limits() const { return budget_.limits(); }

  void check_required() {
    for (const auto& e : array_of(c_.doc, "extensionsRequired", what_)) {
      if (!e.is_string()) throw Error(what_ + ": extensionsRequired holds a non-string");
      if (e.get<std::string>() == "KHR_texture_basisu")
        throw Error(
            what_ + ": required extension KHR_texture_basisu: " + std::string(kNoKtx2Decoder),
            ErrorCode::kUnsupported);
      if (!is_supported_required_extension(e.get<std::string>()))
        throw Error(what_ + ": required extension " + e.get<std::string>() + " is not supported",
                    ErrorCode::kUnsupported);
    }
  }

  static const char* meshopt_of(const json& o) {
    if (!o.is_object() || !o.contains("extensions") || !o["extensions"].is_object()) return nullptr;
    for (const char* name : kMeshopt)
      if (o["extensions"].contains(name)) return name;
    return nullptr;
  }

  // Buffers with data first (an external .bin file of a file on disk raises the budget as the
  // file's own bytes do); meshopt fallback buffers are only declared here: decode_meshopt
  // allocates them once the views that fill them are checked.
  void load_buffers() {
    auto& buffers = array_of(c_.doc, "buffers", what_);
    data_.resize(buffers.size());
    declared_.assign(buffers.size(), 0);
    fallback_.assign(buffers.size(), false);
    for (std::size_t i = 0; i < buffers.size(); ++i) {
      json& b = buffers[i];
      const std::string at = what_ + " buffers[" + std::to_string(i) + "]";
      if (b.contains("uri")) {
        if (!b["uri"].is_string()) throw Error(at + ": uri is not a string");
        const std::string& uri = b["uri"].get_ref<const std::string&>();
        data_[i] = read_uri(uri, at, dir_, nullptr);
        if (!uri.starts_with("data:")) budget_.add_file_bytes(data_[i].size());
        changed_ = true;
      } else if (c_.glb && i == 0) {
        data_[i] = std::move(c_.bin);  // one copy of the BIN chunk, however large
      } else if (meshopt_of(b)) {
        fallback_[i] = true;
        declared_[i] = size_field(b, "byteLength", at);
        continue;
      } else {
        throw Error(at + ": buffer has no data");
      }
      const std::size_t length = size_field(b, "byteLength", at);
      if (data_[i].size() < length)
        throw Error(at + ": byteLength " + std::to_string(length) + " exceeds its " +
                    std::to_string(data_[i].size()) + " bytes");
      declared_[i] = data_[i].size();
    }
  }

  // The bytes [offset, offset + length) of buffer `index`, checked (against the declared length
  // of a fallback buffer not yet allocated).
  std::string_view slice(std::size_t index, std::size_t offset, std::size_t length,
                         const std::string& at) const {
    if (index >= data_.size())
      throw Error(at + ": buffer " + std::to_string(index) + " does not exist");
    const std::size_t size = std::max(data_[index].size(), declared_[index]);
    if (offset > size || length > size - offset)
      throw Error(at + ": byte range runs past the end of buffer " + std::to_string(index));
    if (data_[index].size() < size) return {};  // not allocated yet
    return std::string_view(data_[index]).substr(offset, length);
  }

  // Every meshopt view is checked and its decoded size charged before any fallback buffer is
  // allocated or any stream decoded.
  void decode_meshopt() {
    auto& views = array_of(c_.doc, "bufferViews", what_);
    struct Job {
      std::size_t view, count, stride, dst_buffer, dst_offset;
      std::string at, mode, filter;
      const char* ext;
    };
    std::vector<Job> jobs;
    for (std::size_t i = 0; i < views.size(); ++i) {
      json& v = views[i];
      const char* ext = meshopt_of(v);
      if (!ext) continue;
      const std::string at = what_ + " bufferViews[" + std::to_string(i) + "]";
      const json& e = v["extensions"][ext];
      if (!e.is_object()) throw Error(at + ": " + ext + " is not an object");
      Job job{i,
              size_field(e, "count", at),
              size_field(e, "byteStride", at),
              size_field(v, "buffer", at),
              size_field(v, "byteOffset", at),
              at,
              e.value("mode", std::string()),
              e.value("filter", std::string("NONE")),
              ext};
      (void)slice(size_field(e, "buffer", at), size_field(e, "byteOffset", at),
                  size_field(e, "byteLength", at), at);
      const std::size_t dst_length = size_field(v, "byteLength", at);
      (void)slice(job.dst_buffer, job.dst_offset, dst_length, at);
      budget_.charge(product(job.count, job.stride), at, "meshopt decode");
      if (job.stride == 0 || job.stride > 256 || job.count > dst_length / job.stride)
        throw Error(at + ": meshopt count and stride do not fit the buffer view");
      jobs.push_back(std::move(job));
    }
    auto& buffers = array_of(c_.doc, "buffers", what_);
    for (std::size_t i = 0; i < buffers.size(); ++i) {
      if (!fallback_[i]) continue;
      budget_.charge(declared_[i], what_ + " buffers[" + std::to_string(i) + "]",
                     "meshopt fallback buffer");
      data_[i].assign(declared_[i], '\0');  // filled by the views below
      for (const char* name : kMeshopt) remove_extension(buffers[i], name);
    }
    for (const Job& job : jobs) {
      json& v = views[job.view];
      const json& e = v["extensions"][job.ext];
      const std::string_view src =
          slice(size_field(e, "buffer", job.at), size_field(e, "byteOffset", job.at),
                size_field(e, "byteLength", job.at), job.at);
      const std::size_t count = job.count, stride = job.stride;
      auto* dst = reinterpret_cast<unsigned char*>(data_[job.dst_buffer].data() + job.dst_offset);
      const auto* in = reinterpret_cast<const unsigned char*>(src.data());
      const std::string& mode = job.mode;
      const std::string& filter = job.filter;
      int rc = -1;
      if (mode == "ATTRIBUTES" && stride % 4 == 0) {
        rc = meshopt_decodeVertexBuffer(dst, count, stride, in, src.size());
      } else if (mode == "TRIANGLES" && (stride == 2 || stride == 4) && count % 3 == 0) {
        rc = meshopt_decodeIndexBuffer(dst, count, stride, in, src.size());
      } else if (mode == "INDICES" && (stride == 2 || stride == 4)) {
        rc = meshopt_decodeIndexSequence(dst, count, stride, in, src.size());
      }
      if (rc != 0) throw Error(job.at + ": meshopt data cannot be decoded (mode " + mode + ")");
      if (filter == "OCTAHEDRAL" && (stride == 4 || stride == 8))
        meshopt_decodeFilterOct(dst, count, stride);
      else if (filter == "QUATERNION" && stride == 8)
        meshopt_decodeFilterQuat(dst, count, stride);
      else if (filter == "EXPONENTIAL" && stride % 4 == 0)
        meshopt_decodeFilterExp(dst, count, stride);
      else if (filter != "NONE")
        throw Error(job.at + ": meshopt filter " + filter + " does not fit stride " +
                    std::to_string(stride));
      remove_extension(v, job.ext);
      changed_ = true;
    }
    for (const char* name : kMeshopt) drop_from_lists(c_.doc, name);
  }

  // Appends bytes as a new buffer (merged by assemble) and returns a buffer view over it.
  std::size_t add_view(std::string bytes) {
    auto& views = c_.doc["bufferViews"];
    if (!views.is_array()) views = json::array();
    json v = {{"buffer", data_.size()}, {"byteOffset", 0}, {"byteLength", bytes.size()}};
    declared_.push_back(bytes.size());
    fallback_.push_back(false);
    data_.push_back(std::move(bytes));
    views.push_back(v);
    return views.size() - 1;
  }

  json& accessor(const json& index, const std::string& at) {
    auto& accessors = array_of(c_.doc, "accessors", what_);
    if (!index.is_number_integer() || index.get<std::int64_t>() < 0 ||
        index.get<std::size_t>() >= accessors.size())
      throw Error(at + ": accessor index out of range");
    return accessors[index.get<std::size_t>()];
  }

  void decode_draco_primitives() {
    auto& meshes = array_of(c_.doc, "meshes", what_);
    for (std::size_t mi = 0; mi < meshes.size(); ++mi) {
      auto& prims = array_of(meshes[mi], "primitives", what_);
      for (std::size_t pi = 0; pi < prims.size(); ++pi) {
        json& p = prims[pi];
        if (!p.is_object() || !p.contains("extensions") || !p["extensions"].is_object() ||
            !p["extensions"].contains("KHR_draco_mesh_compression"))
          continue;
        decode_draco_primitive(p, what_ + " meshes[" + std::to_string(mi) + "].primitives[" +
                                      std::to_string(pi) + "]");
        changed_ = true;
      }
    }
    drop_from_lists(c_.doc, "KHR_draco_mesh_compression");
  }

  void decode_draco_primitive(json& p, const std::string& at) {
    const json& e = p["extensions"]["KHR_draco_mesh_compression"];
    if (!e.is_object()) throw Error(at + ": KHR_draco_mesh_compression is not an object");
    const std::size_t view = size_field(e, "bufferView", at);
    auto& views = array_of(c_.doc, "bufferViews", what_);
    if (view >= views.size()) throw Error(at + ": Draco buffer view does not exist");
    const json& v = views[view];
    const std::string_view src = slice(size_field(v, "buffer", at), size_field(v, "byteOffset", at),
                                       size_field(v, "byteLength", at), at);
    if (!p.contains("indices") || !e.contains("attributes") || !e["attributes"].is_object() ||
        !p.contains("attributes") || !p["attributes"].is_object())
      throw Error(at + ": Draco primitive without indices or attributes");
    json& idx = accessor(p["indices"], at);
    const std::size_t index_count = size_field(idx, "count", at);
    std::vector<DracoRequest> requests;
    std::vector<json*> targets;
    std::size_t point_bytes = 0;  // decoded bytes per point, over the requested attributes
    for (const auto& [name, id] : e["attributes"].items()) {
      if (!p["attributes"].contains(name) || !id.is_number_integer())
        throw Error(at + ": Draco attribute " + name + " has no accessor");
      json& a = accessor(p["attributes"][name], at);
      DracoRequest r;
      r.unique_id = id.get<int>();
      r.component_type = a.value("componentType", 0);
      static const std::map<std::string, int> comps = {
          {"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4}, {"MAT4", 16}};
      const auto it = comps.find(a.value("type", std::string()));
      if (it == comps.end()) throw Error(at + ": bad accessor type for " + name);
      r.components = it->second;
      r.count = size_field(a, "count", at);
      point_bytes += static_cast<std::size_t>(r.components) * 4;
      requests.push_back(std::move(r));
      targets.push_back(&a);
    }
    // The stream's own header says how many faces and points it decodes to: checked against the
    // accessors, and what decoding them allocates (Draco's mesh and corner table, its attribute
    // values, our converted copies) charged, before the decoder runs.
    const DracoCounts counts = draco_counts(src, at);
    if (product(counts.faces, 3) != index_count)
      throw Error(at + ": Draco stream has " + std::to_string(product(counts.faces, 3)) +
                  " indices, the accessor " + std::to_string(index_count));
    std::size_t points = counts.points;
    for (const auto& r : requests) {
      if (counts.sequential && r.count != counts.points)
        throw Error(at + ": Draco stream has " + std::to_string(counts.points) +
                    " points, the accessor " + std::to_string(r.count));
      points = std::max(points, r.count);
    }
    // Our copies (uint32 indices, attributes as the accessors declare them, at most 4 bytes a
    // component) and Draco's own mesh of about the same size.
    const std::size_t out = product(product(counts.faces, 3), 4) + product(points, point_bytes);
    budget_.charge(product(out, 2), at, "Draco decode");
    std::string indices;
    decode_draco(src, index_count, indices, requests, at);
    idx["bufferView"] = add_view(std::move(indices));
    idx["componentType"] = 5125;
    idx.erase("byteOffset");
    for (std::size_t k = 0; k < requests.size(); ++k) {
      (*targets[k])["bufferView"] = add_view(std::move(requests[k].out));
      targets[k]->erase("byteOffset");
    }
    remove_extension(p, "KHR_draco_mesh_compression");
  }

  // Every image's header is read (no decoder runs here or in tinygltf) and checked against the
  // image limits; images given by URI get a buffer view.
  void pack_images() {
    auto& images = array_of(c_.doc, "images", what_);
    auto& views = array_of(c_.doc, "bufferViews", what_);
    std::size_t total = 0;
    for (std::size_t i = 0; i < images.size(); ++i) {
      json& im = images[i];
      const std::string at = what_ + " images[" + std::to_string(i) + "]";
      if (!im.is_object()) throw Error(at + ": not an object");
      if (!im.contains("uri")) {
        if (!im.contains("bufferView")) continue;
        const std::size_t vi = size_field(im, "bufferView", at);
        if (vi >= views.size()) throw Error(at + ": buffer view does not exist");
        const json& v = views[vi];
        total += image_cost(slice(size_field(v, "buffer", at), size_field(v, "byteOffset", at),
                                  size_field(v, "byteLength", at), at),
                            at);
        check_texture_total(total, at);
        continue;
      }
      if (!im["uri"].is_string()) throw Error(at + ": uri is not a string");
      const std::string uri = im["uri"].get<std::string>();
      std::string mime;
      std::string bytes = read_uri(uri, at, dir_, &mime);
      total += image_cost(bytes, at);
      check_texture_total(total, at);
      if (mime.empty() || mime == "application/octet-stream") {
        const std::string ext = std::filesystem::path(uri).extension().string();
        mime = ext == ".png"                       ? "image/png"
               : (ext == ".jpg" || ext == ".jpeg") ? "image/jpeg"
               : ext == ".webp"                    ? "image/webp"
               : ext == ".ktx2"                    ? "image/ktx2"
                                                   : "image/png";
      }
      if (!im.contains("mimeType")) im["mimeType"] = mime;
      im["bufferView"] = add_view(std::move(bytes));
      im.erase("uri");
      changed_ = true;
    }
  }

  // What an image decodes to, from its header; an image over the limits is an error, one whose
  // header cannot be read is kept as it is (no decoder of Facecast's takes it: decode_image checks
  // the header again, strictly).
  std::size_t image_cost(std::string_view bytes, const std::string& at) const {
    try {
      return check_image(bytes, at, limits());
    } catch (const Error& e) {
      if (e.code() == ErrorCode::kLimit) throw;
      return 0;
    }
  }

  void check_texture_total(std::size_t total, const std::string& at) const {
    if (total > limits().max_texture_bytes)
      throw Error(at + ": the images decode to " + std::to_string(total) +
                      " bytes in all, over the limit of " +
                      std::to_string(limits().max_texture_bytes) + " (max_texture_bytes)",
                  ErrorCode::kLimit);
  }

  // One buffer: every buffer's bytes one after another (each start 16-byte aligned, so views keep
  // their alignment), views rebased onto it.
  std::string assemble() {
    std::string bin;
    std::vector<std::size_t> base(data_.size());
    for (std::size_t i = 0; i < data_.size(); ++i) {
      while (bin.size() % 16) bin.push_back('\0');
      base[i] = bin.size();
      bin += data_[i];
    }
    for (auto& v : array_of(c_.doc, "bufferViews", what_)) {
      const std::size_t b = size_field(v, "buffer", what_ + " bufferView");
      if (b >= base.size())
        throw Error(what_ + ": buffer view names buffer " + std::to_string(b) +
                    ", which does not exist");
      v["buffer"] = 0;
      v["byteOffset"] = base[b] + size_field(v, "byteOffset", what_);
    }
    if (!bin.empty())
      c_.doc["buffers"] = json::array({{{"byteLength", bin.size()}}});
    else
      c_.doc.erase("buffers");
    std::string text = c_.doc.dump(-1, ' ', false, json::error_handler_t::replace);
    while (text.size() % 4) text.push_back(' ');
    while (bin.size() % 4) bin.push_back('\0');
    std::string out;
    const auto u32 = [&](std::size_t v) {
      const auto x = static_cast<std::uint32_t>(v);
      out.append(reinterpret_cast<const char*>(&x), 4);
    };
    const std::size_t total = 12 + 8 + text.size() + (bin.empty() ? 0 : 8 + bin.size());
    if (total > 0x7FFFFFFF)
      throw Error(what_ + ": the packed GLB exceeds 2 GiB", ErrorCode::kLimit);
    out += "glTF";
    u32(2);
    u32(total);
    u32(text.size());
    out += "JSON";
    out += text;
    if (!bin.empty()) {
      u32(bin.size());
      out.append("BIN\0", 4);
      out += bin;
    }
    return out;
  }

  Container c_;
  std::string what_;
  std::optional<std::filesystem::path> dir_;
  DecodeBudget& budget_;
  std::vector<std::string> data_;
  std::vector<std::size_t> declared_;  // byteLength of each buffer (fallbacks: before allocating)
  std::vector<bool> fallback_;
  bool changed_ = false;
};

}  // namespace

bool is_supported_required_extension(std::string_view name) {
  for (const char* e : kSupportedRequired)
    if (name == e) return true;
  return false;
}

std::string pack_glb(std::string_view bytes, const std::string& what,
                     const std::optional<std::filesystem::path>& base_dir, DecodeBudget& budget) {
  try {
    Container c = split_container(bytes, what, budget.limits());
    check_counts(c.doc, what, budget.limits());
    Packer packer(std::move(c), what, base_dir, budget);
    return packer.run(bytes);
  } catch (const nlohmann::json::exception& e) {
    throw Error(what + ": malformed glTF JSON (" + e.what() + ")");
  }
}

}  // namespace facecast::rig::detail
