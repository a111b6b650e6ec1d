#pragma once
// Hostile glTF files for the tests (anim, server) and the fuzzers' seeds: small files that declare
// a cost far beyond their size (decode_limits.hpp). Built in code: nothing hostile is committed.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace facecast::test::hostile {

/// A GLB from its JSON text and BIN bytes (the text may be JSON no parser could build).
std::string make_glb(std::string text, std::string bin);

/// A glTF document with one BIN buffer.
struct Doc {
  nlohmann::json doc;
  std::string bin;
  std::string glb() const { return make_glb(doc.dump(), bin); }
};

/// One triangle (accessor 0: POSITION, 1: a morph target, 2: indices; buffer views 0..2) with
/// one morph target "jawOpen"; its BIN padded to `pad` bytes.
Doc triangle(std::size_t pad = 0);

/// "[[[...]]]" nesting `depth` levels.
std::string nested(std::size_t depth);
/// The JSON text of `d` with `member` ("\"key\":value") added to its top-level object.
std::string with_member(const Doc& d, const std::string& member);
/// A LEB128 varint as Draco writes it.
std::string varint(std::uint64_t v);
/// A Draco 2.2 triangle-mesh header (no metadata) declaring `faces` and `points`, then padding.
std::string draco_header(bool edgebreaker, std::uint64_t faces, std::uint64_t points);
/// A PNG signature and IHDR chunk declaring `w` x `h` RGBA, and nothing else.
std::string png_header(std::uint32_t w, std::uint32_t h);
/// The triangle whose primitive is the Draco stream `draco` (in buffer view 3).
Doc with_draco(const std::string& draco);
/// The triangle in a 2 MiB file whose meshopt view `ext` (EXT_ or KHR_meshopt_compression), and
/// the fallback buffer it fills, claim 2 GiB.
Doc meshopt_2gib(const char* ext);
/// Adds an image of `bytes` (in a new buffer view) to `d`.
void add_image(Doc& d, const std::string& bytes, const char* mime);

/// The attacks, one file each: what it is, its bytes, and the start of the error it must get
/// (after the upload's name).
struct File {
  std::string name, bytes, error;
};
/// deep_json (100,000 levels, 400 KB), meshopt_2gib (2 GiB asked by a 2 MiB file), draco_counts
/// (10^9 faces in a 100-byte stream), sparse_rows (80 million rows without data), png_side (a
/// 100000 x 100000 PNG header).
std::vector<File> glb_attacks();

}  // namespace facecast::test::hostile
