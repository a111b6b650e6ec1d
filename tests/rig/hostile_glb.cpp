// Hostile glTF files (see hostile_glb.hpp).
#include "hostile_glb.hpp"

#include <cstring>

namespace facecast::test::hostile {

using nlohmann::json;

// A GLB from its JSON text and BIN bytes (the text may be JSON no parser here could build).
std::string make_glb(std::string text, std::string bin) {
  while (text.size() % 4) text += ' ';
  while (bin.size() % 4) bin += '\0';
  std::string out;
  const auto u32 = [&](std::size_t v) {
    const auto x = static_cast<std::uint32_t>(v);
    out.append(reinterpret_cast<const char*>(&x), 4);
  };
  out += "glTF";
  u32(2);
  u32(12 + 8 + text.size() + 8 + bin.size());
  u32(text.size());
  out += "JSON";
  out += text;
  u32(bin.size());
  out.append("BIN\0", 4);
  out += bin;
  return out;
}

Doc triangle(std::size_t pad) {
  Doc d;
  const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const float delta[9] = {0, 0, 0, 0, 0, 0.5f, 0, 0, 0};
  const std::uint32_t idx[3] = {0, 1, 2};
  d.bin.append(reinterpret_cast<const char*>(pos), sizeof pos);
  d.bin.append(reinterpret_cast<const char*>(delta), sizeof delta);
  d.bin.append(reinterpret_cast<const char*>(idx), sizeof idx);
  if (d.bin.size() < pad) d.bin.resize(pad, '\0');
  d.doc = json::parse(R"({
    "asset": {"version": "2.0"},
    "buffers": [{"byteLength": 0}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                    {"buffer": 0, "byteOffset": 36, "byteLength": 36},
                    {"buffer": 0, "byteOffset": 72, "byteLength": 12}],
    "accessors": [
      {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
       "min": [0, 0, 0], "max": [1, 1, 0]},
      {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
      {"bufferView": 2, "componentType": 5125, "count": 3, "type": "SCALAR"}],
    "meshes": [{"name": "face", "primitives": [{"attributes": {"POSITION": 0}, "indices": 2,
                "targets": [{"POSITION": 1}]}], "extras": {"targetNames": ["jawOpen"]}}],
    "nodes": [{"mesh": 0}],
    "scenes": [{"nodes": [0]}],
    "scene": 0})");
  d.doc["buffers"][0]["byteLength"] = d.bin.size();
  return d;
}

std::string nested(std::size_t depth) {
  return std::string(depth, '[') + std::string(depth, ']');
}

// The JSON of `d` with `member` (text) added to its top-level object.
std::string with_member(const Doc& d, const std::string& member) {
  std::string text = d.doc.dump();
  text.insert(text.size() - 1, "," + member);
  return text;
}

std::string varint(std::uint64_t v) {
  std::string out;
  do {
    const auto byte = static_cast<unsigned char>(v & 0x7F);
    v >>= 7;
    out.push_back(static_cast<char>(v ? byte | 0x80 : byte));
  } while (v);
  return out;
}

// A Draco 2.2 triangle-mesh header (no metadata) that declares `faces` and `points`.
std::string draco_header(bool edgebreaker, std::uint64_t faces, std::uint64_t points) {
  std::string s = "DRACO";
  s += '\x02';
  s += '\x02';
  s += '\x01';                         // triangular mesh
  s += edgebreaker ? '\x01' : '\x00';  // method
  s.append("\0\0", 2);                 // flags
  if (edgebreaker) {
    s += '\x00';  // standard traversal
    s += varint(points) + varint(faces);
    s += '\x00';                     // attribute data
    s += varint(faces) + varint(0);  // symbols, split symbols
  } else {
    s += varint(faces) + varint(points);
  }
  s.append(64, '\0');
  return s;
}

// A PNG signature and IHDR chunk declaring `w` x `h` RGBA, and nothing else.
std::string png_header(std::uint32_t w, std::uint32_t h) {
  std::string s("\x89PNG\r\n\x1a\n", 8);
  const auto be = [&](std::uint32_t v) {
    for (int k = 3; k >= 0; --k) s += static_cast<char>((v >> (8 * k)) & 0xFF);
  };
  be(13);
  s += "IHDR";
  be(w);
  be(h);
  s += '\x08';  // bit depth
  s += '\x06';  // RGBA
  s.append(3, '\0');
  be(0);  // CRC (not checked by a header reader)
  return s;
}

// `d` with an image of `bytes` in a new buffer view.
void add_image(Doc& d, const std::string& bytes, const char* mime) {
  while (d.bin.size() % 4) d.bin += '\0';
  const std::size_t at = d.bin.size();
  d.bin += bytes;
  d.doc["buffers"][0]["byteLength"] = d.bin.size();
  d.doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", at}, {"byteLength", bytes.size()}});
  d.doc["images"].push_back({{"bufferView", d.doc["bufferViews"].size() - 1}, {"mimeType", mime}});
}

Doc with_draco(const std::string& draco) {
  Doc d = triangle();
  const std::size_t at = d.bin.size();
  d.bin += draco;
  d.doc["buffers"][0]["byteLength"] = d.bin.size();
  d.doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", at}, {"byteLength", draco.size()}});
  d.doc["meshes"][0]["primitives"][0]["extensions"] = {
      {"KHR_draco_mesh_compression", {{"bufferView", 3}, {"attributes", {{"POSITION", 0}}}}}};
  return d;
}

Doc meshopt_2gib(const char* ext) {
  Doc d = triangle(2 << 20);
  d.doc["buffers"].push_back(
      {{"byteLength", 1ull << 31}, {"extensions", {{ext, {{"fallback", true}}}}}});
  d.doc["bufferViews"].push_back({{"buffer", 1},
                                  {"byteLength", 1ull << 31},
                                  {"byteStride", 16},
                                  {"extensions",
                                   {{ext,
                                     {{"buffer", 0},
                                      {"byteOffset", 84},
                                      {"byteLength", 1024},
                                      {"byteStride", 16},
                                      {"count", (1ull << 31) / 16},
                                      {"mode", "ATTRIBUTES"}}}}}});
  d.doc["extensionsUsed"] = {ext};
  return d;
}

std::vector<File> glb_attacks() {
  std::vector<File> out;
  {
    const Doc d = triangle();
    out.push_back({"deep_json", make_glb(with_member(d, "\"extras\":" + nested(200000)), d.bin),
                   ": JSON nests deeper than 64 levels at byte "});
  }
  out.push_back({"meshopt_2gib", meshopt_2gib("EXT_meshopt_compression").glb(),
                 " bufferViews[3]: meshopt decode of 2147483648 bytes is over the budget of "});
  {
    Doc d = with_draco(draco_header(true, 1000000000, 1000000000));
    d.doc["accessors"][2]["count"] = 3000000000u;
    d.doc["accessors"][0]["count"] = 1000000000u;
    out.push_back({"draco_counts", d.glb(),
                   " meshes[0].primitives[0]: Draco decode of 48000000000 bytes is over the "
                   "budget of "});
  }
  {
    Doc d = triangle();
    d.doc["accessors"][1] = json::parse(R"({"componentType": 5126, "count": 80000000,
        "type": "VEC3", "sparse": {"count": 1,
          "indices": {"bufferView": 2, "componentType": 5125},
          "values": {"bufferView": 1}}})");
    out.push_back({"sparse_rows", d.glb(),
                   " meshes[0].primitives[0] target 0: sparse accessor read of 960000004 bytes"});
  }
  {
    Doc d = triangle();
    add_image(d, png_header(100000, 100000), "image/png");
    out.push_back({"png_side", d.glb(),
                   " images[0]: png image of 100000x100000 is over the limit of 8192 pixels a "
                   "side (max_image_side)"});
  }
  return out;
}

}  // namespace facecast::test::hostile
