// libFuzzer target: the avatar file parsers that uploads reach. Build with -DFACECAST_FUZZ=ON
// -DCMAKE_CXX_COMPILER=clang++; run
//   ./fuzz_glb -max_total_time=600 -rss_limit_mb=2048 tests/fuzz/corpus/fuzz_glb
// (and ./fuzz_gltf, ./fuzz_obj the same way; scripts/fuzz.sh does it). The corpus' limit_* seeds
// (tests/fuzz/make_decode_seeds.py writes them) are one tiny file per class of hostile file that
// DecodeLimits bounds (deep JSON, meshopt and Draco sizes, sparse rows, image headers, OBJ lines
// and faces), so that mutations start next to each check. FACECAST_FUZZ_FORMAT picks the input (1:
// GLB/VRM bytes, 3: .gltf JSON text, 2: OBJ). glTF goes through the avatar document (packing,
// meshopt and Draco decoding, tinygltf), both views, a write-back of the shapes, the document's GLB
// and Facecast's own GLB writer. Anything but facecast::Error (a crash, a sanitizer report, another
// exception, running out of memory on a declared size) is a bug.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "facecast/core/error.hpp"
#include "facecast/rig/avatar_view.hpp"
#include "facecast/rig/rig_io.hpp"

namespace {

[[maybe_unused]] void fuzz_gltf(std::string_view bytes, const char* name) {
  using namespace facecast::rig;
  AvatarDocument doc = AvatarDocument::parse(bytes, name);
  const AvatarView all = make_view(doc, {.all_meshes = true});
  (void)glb_bytes(all.rig, GlbOptions{.mesh_per_group = true});
  const AvatarView face = make_view(doc);
  Rig edited = face.rig;
  for (auto& s : edited.shapes) s.deltas *= 0.5f;
  write_back(doc, face, edited);
  (void)doc.glb_bytes();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  try {
#if FACECAST_FUZZ_FORMAT == 1
    fuzz_gltf(bytes, "fuzz.glb");
#elif FACECAST_FUZZ_FORMAT == 3
    fuzz_gltf(bytes, "fuzz.gltf");
#else
    const auto rig = facecast::rig::parse_obj(bytes, "fuzz.obj");
    (void)facecast::rig::glb_bytes(rig);
#endif
  } catch (const facecast::Error&) {
  }
  return 0;
}
