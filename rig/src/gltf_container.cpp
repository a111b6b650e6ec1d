// A glTF container opened for packing: the GLB's chunks or the .gltf text, the JSON checked for
// nesting, size and object counts against the DecodeLimits before it is parsed further.
#include "gltf_container.hpp"

#include <cstring>

#include "facecast/core/error.hpp"
#include "facecast/core/json_limits.hpp"

namespace facecast::rig::detail {

using nlohmann::json;

namespace {

// The values (and object keys) of JSON text, counted without parsing: an upper bound from the
// separators outside strings. Stops counting past `stop_at`.
std::size_t json_values(std::string_view text, std::size_t stop_at) {
  std::size_t n = 1;
  bool in_string = false, escaped = false;
  for (const char c : text) {
    if (in_string) {
      if (escaped)
        escaped = false;
      else if (c == '\\')
        escaped = true;
      else if (c == '"')
        in_string = false;
      continue;
    }
    if (c == '"') {
      in_string = true;
    } else if (c == ',' || c == ':' || c == '[' || c == '{') {
      if (++n > stop_at) return n;
    }
  }
  return n;
}

std::uint32_t u32_at(std::string_view b, std::size_t at) {
  std::uint32_t v;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}

}  // namespace

Container split_container(std::string_view bytes, const std::string& what,
                          const DecodeLimits& limits) {
  Container c;
  std::string_view text = bytes;
  if (bytes.size() >= 4 && bytes.substr(0, 4) == "glTF") {
    c.glb = true;
    if (bytes.size() < 20) throw Error(what + ": GLB header is truncated");
    if (u32_at(bytes, 4) != 2) throw Error(what + ": only GLB version 2 is supported");
    const std::size_t json_len = u32_at(bytes, 12);
    if (u32_at(bytes, 16) != 0x4E4F534A || json_len > bytes.size() - 20)
      throw Error(what + ": GLB JSON chunk is missing or truncated");
    text = bytes.substr(20, json_len);
    const std::size_t at = (20 + json_len + 3) / 4 * 4;
    if (at + 8 <= bytes.size() && u32_at(bytes, at + 4) == 0x004E4942) {
      const std::size_t bin_len = u32_at(bytes, at);
      if (bin_len > bytes.size() - at - 8) throw Error(what + ": GLB BIN chunk is truncated");
      c.bin = std::string(bytes.substr(at + 8, bin_len));
    }
  }
  // Before any parser: nesting (parsers recurse) and the number of values (each costs a parser
  // many times its bytes).
  check_json_depth(text, limits.max_json_depth, what);
  if (const std::size_t n = json_values(text, limits.max_json_values); n > limits.max_json_values)
    throw Error(what + ": the glTF JSON holds more than " + std::to_string(limits.max_json_values) +
                    " values (max_json_values)",
                ErrorCode::kLimit);
  c.doc = json::parse(text, nullptr, false);
  if (c.doc.is_discarded() || !c.doc.is_object())
    throw Error(what + ": the glTF JSON is not a valid JSON object");
  return c;
}

// A JSON array member (empty when absent); anything else is an error naming the key.
json& array_of(json& o, const char* key, const std::string& what) {
  thread_local json empty;
  if (!o.is_object() || !o.contains(key)) return empty = json::array();
  if (!o[key].is_array()) throw Error(what + ": '" + key + "' is not an array");
  return o[key];
}

// Counts of glTF objects, checked on the parsed JSON before tinygltf builds its (much larger)
// structures from it.
void check_counts(json& doc, const std::string& what, const DecodeLimits& limits) {
  const auto over = [&](std::size_t n, std::size_t max, const std::string& field, const char* key) {
    if (n > max)
      throw Error(what + ": " + field + " holds " + std::to_string(n) + ", over the limit of " +
                      std::to_string(max) + " (" + key + ")",
                  ErrorCode::kLimit);
  };
  over(array_of(doc, "nodes", what).size(), limits.max_nodes, "nodes", "max_nodes");
  over(array_of(doc, "meshes", what).size(), limits.max_meshes, "meshes", "max_meshes");
  over(array_of(doc, "accessors", what).size(), limits.max_accessors, "accessors", "max_accessors");
  over(array_of(doc, "bufferViews", what).size(), limits.max_accessors, "bufferViews",
       "max_accessors");
  over(array_of(doc, "images", what).size(), limits.max_images, "images", "max_images");
  // Every other array of objects: no more of them than of accessors.
  for (const char* key :
       {"buffers", "materials", "textures", "samplers", "skins", "animations", "cameras", "scenes"})
    over(array_of(doc, key, what).size(), limits.max_accessors, key, "max_accessors");
  std::size_t primitives = 0, targets = 0, joints = 0, channels = 0;
  for (auto& mesh : array_of(doc, "meshes", what)) {
    auto& prims = array_of(mesh, "primitives", what);
    primitives += prims.size();
    for (auto& p : prims) targets += array_of(p, "targets", what).size();
  }
  for (auto& skin : array_of(doc, "skins", what)) joints += array_of(skin, "joints", what).size();
  for (auto& a : array_of(doc, "animations", what))
    channels += array_of(a, "channels", what).size() + array_of(a, "samplers", what).size();
  over(primitives, limits.max_primitives, "the meshes' primitives", "max_primitives");
  over(targets, limits.max_morph_targets, "the primitives' morph targets", "max_morph_targets");
  over(joints, limits.max_joints, "the skins' joints", "max_joints");
  over(channels, limits.max_accessors, "the animations' channels and samplers", "max_accessors");
}

}  // namespace facecast::rig::detail
