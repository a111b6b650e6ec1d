// Hostile avatar and rig files that declare a cost far beyond their size (rig/decode_limits.hpp):
// each is refused from what it declares, with a one-line Error(kLimit) naming the file and the
// field, quickly and before anything of that size is parsed, decoded or allocated. The files are
// built here (nothing hostile is committed).
#include <catch2/catch.hpp>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "build_paths.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/rig/avatar_document.hpp"
#include "facecast/rig/avatar_view.hpp"
#include "facecast/rig/decode_limits.hpp"
#include "facecast/rig/rig_io.hpp"
#include "hostile_glb.hpp"

using namespace facecast;
using namespace facecast::rig;
using nlohmann::json;
using namespace facecast::test::hostile;

namespace {

struct Outcome {
  std::string message = "(no error)";
  ErrorCode code = ErrorCode::kInternal;
  double seconds = 0;
};

template <typename F>
Outcome outcome_of(F&& f) {
  Outcome o;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    f();
  } catch (const Error& e) {
    o.message = e.what();
    o.code = e.code();
  }
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return o;
}

Outcome parse_outcome(const std::string& bytes, const DecodeLimits& limits = {},
                      const char* name = "upload.glb") {
  return outcome_of([&] { (void)parse_glb(bytes, name, limits); });
}

// The refusal every test expects: a limit, one line, quickly.
void check_refused(const Outcome& o, const std::string& starts_with) {
  INFO(o.message);
  CHECK(o.code == ErrorCode::kLimit);
  CHECK(o.message.rfind(starts_with, 0) == 0);
  CHECK(o.message.find('\n') == std::string::npos);
  CHECK(o.seconds < 2.0);
}

}  // namespace

TEST_CASE("the limits' fixture parses", "[rig][glb][limits]") {
  const Rig rig = parse_glb(triangle().glb(), "upload.glb");
  CHECK(rig.vertex_count() == 3);
  REQUIRE(rig.shapes.size() == 1);
  CHECK(rig.shapes[0].name == "jawOpen");
}

TEST_CASE("glTF JSON nesting is bounded before a parser sees it", "[rig][glb][gltf][limits]") {
  const Doc d = triangle();
  SECTION("a GLB whose JSON nests 100,000 levels deep") {
    const std::string glb = make_glb(with_member(d, "\"extras\":" + nested(100000)), d.bin);
    const Outcome o = parse_outcome(glb);
    check_refused(o, "upload.glb: JSON nests deeper than 64 levels at byte ");
  }
  SECTION("a .gltf whose JSON nests 100,000 levels deep") {
    Doc t = d;
    t.doc["buffers"][0]["uri"] =
        "data:application/octet-stream;base64,"
        "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAAAAAAIA/"
        "AAAAAAAAAAAAAAAAAAAAAAAAAD8AAAAAAAAAAAAAAAAAAAAAAQAAAAIAAAA=";
    const Outcome o =
        parse_outcome(with_member(t, "\"extras\":" + nested(100000)), {}, "upload.gltf");
    check_refused(o, "upload.gltf: JSON nests deeper than 64 levels at byte ");
  }
  SECTION("brackets inside a string do not nest") {
    const std::string glb =
        make_glb(with_member(d, "\"extras\":{\"note\":\"" + nested(100000) + "\"}"), d.bin);
    CHECK(parse_glb(glb, "upload.glb").vertex_count() == 3);
  }
  SECTION("the depth is a setting") {
    DecodeLimits tight;
    tight.max_json_depth = 4;
    const std::string glb = make_glb(with_member(d, "\"extras\":" + nested(4)), d.bin);
    check_refused(parse_outcome(glb, tight), "upload.glb: JSON nests deeper than 4 levels");
    CHECK(parse_glb(glb, "upload.glb").vertex_count() == 3);
  }
}

TEST_CASE("the values of the glTF JSON are counted before it is parsed", "[rig][glb][limits]") {
  const Doc d = triangle();
  std::string many = "\"extras\":[0";
  for (int i = 0; i < 1100000; ++i) many += ",0";
  many += "]";
  check_refused(parse_outcome(make_glb(with_member(d, many), d.bin)),
                "upload.glb: the glTF JSON holds more than 1048576 values (max_json_values)");
}

TEST_CASE("a meshopt view's decoded size is budgeted before anything is allocated",
          "[rig][glb][limits]") {
  // A 2 MiB GLB whose meshopt view (and the fallback buffer it fills) claims 2 GiB.
  for (const char* ext : {"EXT_meshopt_compression", "KHR_meshopt_compression"}) {
    const std::string glb = meshopt_2gib(ext).glb();
    INFO(ext);
    const Outcome o = parse_outcome(glb);
    check_refused(o,
                  "upload.glb bufferViews[3]: meshopt decode of 2147483648 bytes is over the "
                  "budget of " +
                      std::to_string(glb.size() * 64) + " (64 x the " + std::to_string(glb.size()) +
                      "-byte file)");
    // The absolute bound applies when it is the smaller.
    DecodeLimits small;
    small.max_decoded_bytes = 64 << 20;
    check_refused(parse_outcome(glb, small),
                  "upload.glb bufferViews[3]: meshopt decode of 2147483648 bytes is over the "
                  "budget of 67108864 (max_decoded_bytes)");
  }
}

TEST_CASE("a Draco stream's declared counts are budgeted before the decoder runs",
          "[rig][glb][limits]") {
  for (const bool edgebreaker : {true, false}) {
    INFO((edgebreaker ? "edgebreaker" : "sequential"));
    Doc d = with_draco(draco_header(edgebreaker, 1000000000, 1000000000));
    // Accessors that do not agree with the stream: an error before decoding.
    const Outcome o = parse_outcome(d.glb());
    CHECK(o.message ==
          "upload.glb meshes[0].primitives[0]: Draco stream has 3000000000 indices, the "
          "accessor 3");
    CHECK(o.seconds < 2.0);
    // Accessors that agree: the budget.
    d.doc["accessors"][2]["count"] = 3000000000u;
    d.doc["accessors"][0]["count"] = 1000000000u;
    const Outcome big = parse_outcome(d.glb());
    check_refused(big,
                  "upload.glb meshes[0].primitives[0]: Draco decode of 48000000000 bytes is "
                  "over the budget of ");
  }
  // An edgebreaker stream with more vertices than its faces can hold.
  CHECK_THAT(parse_outcome(with_draco(draco_header(true, 1, 4000000000u)).glb()).message,
             Catch::StartsWith("upload.glb meshes[0].primitives[0]: Draco header declares "
                               "4000000000 vertices for 1 faces"));
}

TEST_CASE("sparse accessors are budgeted as the dense arrays they become", "[rig][glb][limits]") {
  SECTION("a morph target of 80 million rows without data") {
    Doc d = triangle();
    d.doc["accessors"][1] = json::parse(R"({"componentType": 5126, "count": 80000000,
        "type": "VEC3", "sparse": {"count": 1,
          "indices": {"bufferView": 2, "componentType": 5125},
          "values": {"bufferView": 1}}})");
    check_refused(parse_outcome(d.glb()),
                  "upload.glb meshes[0].primitives[0] target 0: sparse accessor read of "
                  "960000004 bytes (after ");
  }
  SECTION("POSITION of 80 million rows without data") {
    Doc d = triangle();
    d.doc["accessors"][0] = json::parse(R"({"componentType": 5126, "count": 80000000,
        "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0], "sparse": {"count": 1,
          "indices": {"bufferView": 2, "componentType": 5125},
          "values": {"bufferView": 0}}})");
    check_refused(parse_outcome(d.glb()),
                  "upload.glb meshes[0].primitives[0] POSITION: sparse accessor read of ");
  }
  SECTION("one mesh drawn by 60,000 nodes") {
    Doc d = triangle(64 << 10);  // 64 KiB of vertices, read again for every node
    d.doc["accessors"][0]["count"] = 5000;
    d.doc["meshes"][0]["primitives"][0].erase("targets");
    d.doc["bufferViews"][0]["byteLength"] = 60000;
    d.doc["nodes"] = json::array();
    d.doc["scenes"][0]["nodes"] = json::array();
    for (int n = 0; n < 60000; ++n) {
      d.doc["nodes"].push_back({{"mesh", 0}});
      d.doc["scenes"][0]["nodes"].push_back(n);
    }
    const Outcome o = outcome_of([&] {
      (void)make_view(AvatarDocument::parse(d.glb(), "upload.glb"), {.all_meshes = true});
    });
    INFO(o.message);
    CHECK(o.code == ErrorCode::kLimit);
    CHECK_THAT(o.message, Catch::Contains("is over the budget of"));
    CHECK(o.seconds < 5.0);
  }
}

TEST_CASE("embedded images are checked from their headers", "[rig][glb][limits]") {
  SECTION("a PNG whose header claims 100000 x 100000") {
    Doc d = triangle();
    add_image(d, png_header(100000, 100000), "image/png");
    check_refused(parse_outcome(d.glb()),
                  "upload.glb images[0]: png image of 100000x100000 is over the limit of 8192 "
                  "pixels a side (max_image_side)");
  }
  SECTION("a JPEG frame header behind an APP segment") {
    std::string jpeg("\xff\xd8\xff\xe0\x00\x10JFIF\0\x01\x01\0\0\x01\0\x01\0\0", 20);
    jpeg += std::string("\xff\xc0\x00\x11\x08\xea\x60\xea\x60\x03", 10);  // 60000 x 60000
    jpeg.append(16, '\0');
    Doc d = triangle();
    add_image(d, jpeg, "image/jpeg");
    check_refused(parse_outcome(d.glb()),
                  "upload.glb images[0]: jpeg image of 60000x60000 is over the limit");
  }
  SECTION("a WebP (VP8X) canvas of 16384 x 16384") {
    std::string webp = "RIFF";
    webp.append("\x40\0\0\0", 4);
    webp += "WEBPVP8X";
    webp.append("\x0a\0\0\0", 4);
    webp.append("\0\0\0\0", 4);
    webp.append("\xff\x3f\x00\xff\x3f\x00", 6);
    webp.append(16, '\0');
    Doc d = triangle();
    add_image(d, webp, "image/webp");
    check_refused(parse_outcome(d.glb()),
                  "upload.glb images[0]: webp image of 16384x16384 is over the limit");
  }
  SECTION("the decoded bytes and the document's total are settings") {
    Doc d = triangle();
    add_image(d, png_header(2048, 2048), "image/png");
    add_image(d, png_header(2048, 2048), "image/png");
    CHECK_NOTHROW(parse_glb(d.glb(), "upload.glb"));
    DecodeLimits one;
    one.max_image_bytes = 8 << 20;
    check_refused(parse_outcome(d.glb(), one),
                  "upload.glb images[0]: png image of 2048x2048 decodes to 16777216 bytes, over "
                  "the limit of 8388608 (max_image_bytes)");
    DecodeLimits total;
    total.max_texture_bytes = 24 << 20;
    check_refused(parse_outcome(d.glb(), total),
                  "upload.glb images[1]: the images decode to 33554432 bytes in all, over the "
                  "limit of 25165824 (max_texture_bytes)");
  }
  SECTION("headers are read, not trusted: a truncated one is an error for the decoder") {
    CHECK_THROWS_WITH(check_image(png_header(1, 1).substr(0, 20), "x.png"),
                      "x.png: PNG header is truncated");
    CHECK(check_image(png_header(640, 480), "x.png") == 640u * 480u * 4u);
    CHECK(read_image_header("GIF89a", "x.gif").format.empty());
  }
}

TEST_CASE("counts of glTF objects are bounded before tinygltf builds them", "[rig][glb][limits]") {
  Doc d = triangle();
  for (int n = 0; n < 20; ++n) d.doc["nodes"].push_back(json::object());
  DecodeLimits tight;
  tight.max_nodes = 16;
  check_refused(parse_outcome(d.glb(), tight),
                "upload.glb: nodes holds 21, over the limit of 16 (max_nodes)");
  Doc t = triangle();
  for (int n = 0; n < 10; ++n)
    t.doc["meshes"][0]["primitives"][0]["targets"].push_back({{"POSITION", 1}});
  tight.max_morph_targets = 8;
  check_refused(parse_outcome(t.glb(), tight),
                "upload.glb: the primitives' morph targets holds 11, over the limit of 8 "
                "(max_morph_targets)");
}

TEST_CASE("OBJ lines, faces and records are bounded", "[rig][obj][limits]") {
  const auto refused = [](const std::string& text, const DecodeLimits& limits = {}) {
    return outcome_of([&] { (void)parse_obj(text, "head.obj", limits); });
  };
  SECTION("a line of 1 MiB") {
    std::string text = "v 0 0 0\n# ";
    text.append(1 << 20, 'x');
    text += '\n';
    check_refused(refused(text),
                  "head.obj:2: line of 1048578 bytes is over the limit of 65536 (max_obj_line)");
  }
  SECTION("a face of 1000 corners") {
    std::string f = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf";
    for (int i = 0; i < 1000; ++i) {
      f += ' ';
      f += static_cast<char>('1' + i % 3);
    }
    check_refused(refused(f + "\n"), "head.obj:4: face of more than 256 corners (max_obj_face)");
  }
  SECTION("faces that triangulate to more than the budget") {
    std::string text = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    std::string f = "f";
    for (int i = 0; i < 250; ++i) f += " 1";
    for (int k = 0; k < 2000; ++k) text += f + "\n";
    CHECK_NOTHROW(parse_obj(text, "head.obj"));  // 2 bytes a corner: 32 x the file
    DecodeLimits tight;
    tight.max_decoded_ratio = 16;
    const Outcome o = refused(text, tight);
    check_refused(o, "head.obj:");
    CHECK_THAT(o.message, Catch::Contains(": face of ") && Catch::Contains("over the budget of") &&
                              Catch::Contains("16 x the"));
  }
}

TEST_CASE("each attack the server is tested with is refused by the loader", "[rig][glb][limits]") {
  for (const auto& f : glb_attacks()) {
    INFO(f.name << ": " << f.bytes.size() << " bytes");
    check_refused(parse_outcome(f.bytes), "upload.glb" + f.error);
  }
}

TEST_CASE("the fuzzers' limit_* seeds are small, and each reaches the check it is next to",
          "[rig][glb][gltf][obj][limits]") {
  const auto root = facecast::test::source_dir() / "tests/fuzz/corpus";
  int files = 0;
  for (const char* target : {"fuzz_glb", "fuzz_gltf", "fuzz_obj"}) {
    for (const auto& entry : std::filesystem::directory_iterator(root / target)) {
      const auto& path = entry.path();
      const std::string stem = path.stem().string(), ext = path.extension().string();
      if (!stem.starts_with("limit_")) continue;
      ++files;
      INFO(path.string());
      CHECK(entry.file_size() < 4096);
      const std::string bytes = read_file(path);
      const Outcome o = outcome_of([&] {
        if (ext == ".obj")
          (void)parse_obj(bytes, "seed" + ext);
        else
          (void)parse_glb(bytes, "seed" + ext);
      });
      INFO(o.message);
      if (stem == "limit_plain" || stem == "limit_string_brackets") {
        CHECK(o.message == "(no error)");
      } else if (stem == "limit_long_line") {
        CHECK(o.code == ErrorCode::kInvalidInput);  // within the limits: no faces
      } else {
        CHECK(o.code == ErrorCode::kLimit);
      }
    }
  }
  CHECK(files == 17);
}
