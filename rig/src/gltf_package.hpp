#pragma once
// Packing any glTF container into one self-contained GLB that tinygltf reads: the GLB or .gltf
// JSON is parsed, its buffers gathered (GLB BIN chunk, data: URIs, and -- only for files on disk --
// external files beside it), EXT_meshopt_compression and KHR_draco_mesh_compression decoded into
// plain buffer views, every buffer merged into one and every image given a buffer view. What
// tinygltf then sees has no URI, no compression and one buffer, so the document saves as a GLB
// with the images' bytes unchanged.
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "decode_budget.hpp"

namespace facecast::rig::detail {

/// Extensions a file may list in extensionsRequired; any other is refused with a one-line error.
bool is_supported_required_extension(std::string_view name);

/// `bytes`: a GLB (or .vrm) or .gltf JSON text; `what` names it in errors. `base_dir`: where
/// external buffers and images of a file on disk lie; nullopt (an upload): any URI that is not a
/// data: URI is an error. Returns the GLB bytes for tinygltf (the input itself when it is a GLB
/// with nothing to pack). Sizes the file declares are checked against what it holds, and the
/// JSON, counts, image headers and decoded sizes against `budget` and its limits, before anything
/// is parsed, decoded or allocated.
std::string pack_glb(std::string_view bytes, const std::string& what,
                     const std::optional<std::filesystem::path>& base_dir, DecodeBudget& budget);

/// What a Draco mesh stream's header declares (read without decoding): faces, and points (a
/// sequential stream: exactly; an edgebreaker stream: the connectivity's vertices, at most three
/// per face). Error naming `what` for a stream that is not a readable Draco mesh.
struct DracoCounts {
  std::size_t faces = 0, points = 0;
  bool sequential = false;
};
DracoCounts draco_counts(std::string_view bytes, const std::string& what);

/// Decodes the Draco-compressed primitive `bytes` into `indices` (uint32) and, per attribute
/// unique id, values converted to `component_type` (a glTF component type) with `components`
/// per vertex. Implemented in gltf_draco.cpp.
struct DracoRequest {
  int unique_id = -1;
  int component_type = 0;  // glTF componentType of the accessor
  int components = 0;      // 1..16
  std::size_t count = 0;   // the accessor's count
  std::string out;         // filled: count * components * component size bytes
};
void decode_draco(std::string_view bytes, std::size_t index_count, std::string& indices,
                  std::vector<DracoRequest>& attributes, const std::string& what);

}  // namespace facecast::rig::detail
