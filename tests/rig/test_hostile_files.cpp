// Hostile avatar files (uploads reach parse_glb and parse_obj): each is a one-line facecast::Error,
// never a crash, an out-of-range read or an allocation of what the file merely declares.
#include <catch2/catch.hpp>
#include <cstdint>
#include <cstring>
#include <nlohmann/json.hpp>

#include "facecast/core/error.hpp"
#include "facecast/rig/rig_io.hpp"

using namespace facecast;
using namespace facecast::rig;
using nlohmann::json;

namespace {

// A GLB split into its JSON and BIN chunks, and put back together.
struct Glb {
  json doc;
  std::string bin;

  static Glb split(const std::string& bytes) {
    std::uint32_t json_len = 0, bin_len = 0;
    std::memcpy(&json_len, bytes.data() + 12, 4);
    Glb g;
    g.doc = json::parse(bytes.substr(20, json_len));
    const std::size_t bin_at = 20 + json_len;
    std::memcpy(&bin_len, bytes.data() + bin_at, 4);
    g.bin = bytes.substr(bin_at + 8, bin_len);
    return g;
  }

  std::string join() const {
    std::string text = doc.dump();
    while (text.size() % 4) text += ' ';
    std::string b = bin;
    while (b.size() % 4) b += '\0';
    std::string out;
    const auto u32 = [&](std::uint32_t v) { out.append(reinterpret_cast<const char*>(&v), 4); };
    out += "glTF";
    u32(2);
    u32(static_cast<std::uint32_t>(12 + 8 + text.size() + 8 + b.size()));
    u32(static_cast<std::uint32_t>(text.size()));
    out += "JSON";
    out += text;
    u32(static_cast<std::uint32_t>(b.size()));
    out.append("BIN\0", 4);
    out += b;
    return out;
  }
};

// Two triangles with UVs and one shape.
Glb small_glb() {
  Rig rig;
  rig.positions.resize(4, 3);
  rig.positions << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0;
  rig.triangles.resize(2, 3);
  rig.triangles << 0, 1, 2, 0, 2, 3;
  rig.normals = vertex_normals(rig.positions, rig.triangles);
  rig.uvs.resize(4, 2);
  rig.uvs << 0, 0, 1, 0, 1, 1, 0, 1;
  rig.triangle_material = {0, 0};
  rig.materials.push_back(Material::solid("skin", {0.8f, 0.6f, 0.5f, 1.0f}));
  Positions d = Positions::Zero(4, 3);
  d(2, 2) = 0.5f;
  rig.shapes.push_back(Blendshape::from_dense("jawOpen", d));
  return Glb::split(glb_bytes(rig));
}

int attribute(const Glb& g, const char* name) {
  return g.doc["meshes"][0]["primitives"][0]["attributes"][name].get<int>();
}

std::string glb_error(const Glb& g) {
  try {
    (void)parse_glb(g.join(), "upload.glb");
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST_CASE("the hostile-GLB fixture itself parses", "[rig][glb][errors]") {
  const Rig rig = parse_glb(small_glb().join(), "upload.glb");
  CHECK(rig.vertex_count() == 4);
  CHECK(rig.uvs.rows() == 4);
}

TEST_CASE("TEXCOORD_0 with fewer elements than POSITION is an error, not an overflow",
          "[rig][glb][errors]") {
  Glb g = small_glb();
  g.doc["accessors"][attribute(g, "TEXCOORD_0")]["count"] = 1;
  CHECK(glb_error(g) ==
        "upload.glb meshes[0].primitives[0] TEXCOORD_0: 1 elements for 4 positions");
}

TEST_CASE("indices out of the file's arrays are errors naming what is missing",
          "[rig][glb][errors]") {
  SECTION("a buffer view that does not exist") {
    Glb g = small_glb();
    g.doc["accessors"][attribute(g, "POSITION")]["bufferView"] = 99;
    CHECK_THAT(glb_error(g), Catch::Contains("upload.glb") && !Catch::Contains("_M_range_check"));
  }
  SECTION("a buffer that does not exist") {
    Glb g = small_glb();
    g.doc["bufferViews"][0]["buffer"] = 7;
    CHECK_THAT(glb_error(g), Catch::Contains("upload.glb") && !Catch::Contains("_M_range_check"));
  }
  SECTION("an index accessor that does not exist") {
    Glb g = small_glb();
    g.doc["meshes"][0]["primitives"][0]["indices"] = 1000;
    CHECK_THAT(glb_error(g), Catch::Contains("upload.glb") && !Catch::Contains("_M_range_check"));
  }
}

TEST_CASE("a huge declared count is refused before anything is allocated", "[rig][glb][errors]") {
  Glb g = small_glb();
  g.doc["accessors"][attribute(g, "POSITION")]["count"] = 4000000000u;
  CHECK_THAT(glb_error(g), Catch::Contains("upload.glb"));
  Glb h = small_glb();
  h.doc["bufferViews"][0]["byteLength"] = 1u << 30;
  CHECK_THAT(glb_error(h), Catch::Contains("upload.glb"));
}

TEST_CASE("a GLB does not read local files through its URIs", "[rig][glb][errors]") {
  Glb g = small_glb();
  g.doc["buffers"].push_back({{"uri", "/etc/hostname"}, {"byteLength", 4}});
  g.doc["bufferViews"].push_back({{"buffer", 1}, {"byteOffset", 0}, {"byteLength", 4}});
  CHECK_THAT(glb_error(g), Catch::Contains("upload.glb") && Catch::Contains("/etc/hostname"));
}

TEST_CASE("an OBJ whose material name is not UTF-8 is an error, not a failed GLB write",
          "[rig][obj][errors]") {
  // Found by fuzz_obj: the name reached the GLB's JSON and nlohmann threw type_error 316.
  const std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl li\x90\nf 1 2 3\n";
  try {
    (void)parse_obj(obj, "head.obj");
    FAIL("no error");
  } catch (const Error& e) {
    CHECK(std::string(e.what()) == "head.obj: material name is not valid UTF-8");
  }
}

namespace {

std::string base64(const std::string& in) {
  static const char* abc = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < in.size(); i += 3) {
    std::uint32_t v = static_cast<unsigned char>(in[i]) << 16;
    if (i + 1 < in.size()) v |= static_cast<unsigned char>(in[i + 1]) << 8;
    if (i + 2 < in.size()) v |= static_cast<unsigned char>(in[i + 2]);
    out += abc[(v >> 18) & 63];
    out += abc[(v >> 12) & 63];
    out += i + 1 < in.size() ? abc[(v >> 6) & 63] : '=';
    out += i + 2 < in.size() ? abc[v & 63] : '=';
  }
  return out;
}

}  // namespace

TEST_CASE("a .gltf upload reads data: URIs and nothing else", "[rig][gltf][errors]") {
  Glb g = small_glb();
  g.doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64(g.bin);
  CHECK(parse_glb(g.doc.dump(), "upload.gltf").vertex_count() == 4);
  g.doc["buffers"][0]["uri"] = "mesh.bin";
  CHECK_THROWS_WITH(parse_glb(g.doc.dump(), "upload.gltf"),
                    "upload.gltf buffers[0]: external file 'mesh.bin' is not read from an upload");
}

TEST_CASE("compressed data that declares more than the file can hold is refused before allocating",
          "[rig][gltf][errors]") {
  SECTION("a meshopt fallback buffer of 1 TB") {
    Glb g = small_glb();
    g.doc["buffers"].push_back(
        {{"byteLength", 1ull << 40},
         {"extensions", {{"EXT_meshopt_compression", {{"fallback", true}}}}}});
    CHECK_THAT(glb_error(g), Catch::Contains("upload.glb buffers[1]: meshopt fallback buffer of "
                                             "1099511627776 bytes is over the budget of"));
  }
  SECTION("a meshopt view whose count overruns its target") {
    Glb g = small_glb();
    g.doc["bufferViews"][0]["extensions"] = {{"EXT_meshopt_compression",
                                              {{"buffer", 0},
                                               {"byteLength", 8},
                                               {"byteStride", 12},
                                               {"count", 4000000000u},
                                               {"mode", "ATTRIBUTES"}}}};
    CHECK_THAT(glb_error(g), Catch::Contains("upload.glb bufferViews[0]"));
  }
  SECTION("a Draco primitive whose data is not a Draco stream") {
    Glb g = small_glb();
    auto& p = g.doc["meshes"][0]["primitives"][0];
    g.doc["accessors"][p["indices"].get<int>()]["count"] = 3000000000u;
    p["extensions"] = {
        {"KHR_draco_mesh_compression", {{"bufferView", 0}, {"attributes", {{"POSITION", 0}}}}}};
    CHECK(glb_error(g) ==
          "upload.glb meshes[0].primitives[0]: Draco header has no DRACO signature "
          "(at byte 0)");
  }
  SECTION("garbage in a meshopt stream") {
    Glb g = small_glb();
    g.doc["buffers"].push_back(json::parse(
        R"({"byteLength": 48, "extensions": {"EXT_meshopt_compression": {"fallback": true}}})"));
    g.doc["bufferViews"].push_back(json::parse(
        R"({"buffer": 1, "byteLength": 48, "extensions": {"EXT_meshopt_compression":
            {"buffer": 0, "byteLength": 16, "byteStride": 12, "count": 4, "mode": "ATTRIBUTES"}}})"));
    CHECK_THAT(glb_error(g), Catch::Contains("meshopt data cannot be decoded"));
  }
}
