#pragma once
// Reading and writing rigs: OBJ (one mesh, or a folder of OBJ blendshapes) and GLB (glTF 2.0 with
// morph targets). All writers are atomic: a failure leaves no partial file.
#include <filesystem>
#include <string>
#include <string_view>

#include "facecast/rig/decode_limits.hpp"
#include "facecast/rig/rest_pose.hpp"
#include "facecast/rig/rig.hpp"

namespace facecast::rig {

/// Reads one OBJ as a rig without shapes. Keeps vertex order exactly as in the file, triangulates
/// polygons as fans, keeps groups ("g") and materials ("usemtl", with Kd colours from "mtllib").
/// Per-vertex UVs and normals take the first value a face assigns to each vertex. Lines, face
/// corners and what the records decode to are bounded by `limits` (max_obj_line, max_obj_face,
/// the decoded budget); a texture's image header by the image limits.
Rig read_obj(const std::filesystem::path& path, const DecodeLimits& limits = {});
/// Parses OBJ text; `name` is used in error messages. Materials come from usemtl names only.
Rig parse_obj(std::string_view text, std::string_view name, const DecodeLimits& limits = {});

/// Reads only the "v" records of an OBJ (fast path for blendshape files).
Positions read_obj_positions(const std::filesystem::path& path);

/// The ICT FaceKit layout: `neutral` plus every other *.obj in `shapes_dir` with the same vertex
/// count, each a shape named by its file stem, in name order. Files that are not blendshapes of
/// this neutral (identity modes, say) can be skipped with `exclude_prefixes`. A shape whose vertex
/// count differs is an error naming the file.
Rig read_obj_shapes(const std::filesystem::path& neutral, const std::filesystem::path& shapes_dir,
                    const std::vector<std::string>& exclude_prefixes = {});

/// Writes the neutral (or `positions` in its place) with the rig's triangles, UVs and materials.
void write_obj(const std::filesystem::path& path, const Rig& rig);
void write_obj(const std::filesystem::path& path, const Rig& rig, const Positions& positions);
/// Writes neutral.obj and <shape>.obj for every shape into `dir`.
void write_obj_folder(const std::filesystem::path& dir, const Rig& rig);

/// GLB: one mesh, one primitive per material sharing the vertex attributes, morph targets as
/// deltas with min/max, names in mesh.extras.targetNames, default weights 0 (see GlbOptions).
std::string glb_bytes(const Rig& rig);
struct GlbOptions {
  /// One mesh per Rig group (its vertices in rig order, the shapes that move it) instead of one
  /// mesh of all vertices in rig order. Textures, PBR materials and the skeleton (a skin) are
  /// written either way when the Rig has them.
  bool mesh_per_group = false;
};
std::string glb_bytes(const Rig& rig, const GlbOptions& options);
void write_glb(const std::filesystem::path& path, const Rig& rig);
/// The face view (avatar_view.hpp) of a self-contained GLB/VRM/.gltf upload, or of a file (whose
/// .gltf may name external buffers and images beside it), read within `limits`.
Rig parse_glb(std::string_view bytes, std::string_view name, const DecodeLimits& limits = {});
Rig read_glb(const std::filesystem::path& path, const DecodeLimits& limits = {});

/// Reads a rig by extension: .glb, .gltf, .vrm (the face view of the avatar) or .obj.
Rig load_rig(const std::filesystem::path& path);
/// The whole avatar, for drawing: every mesh of a .glb/.gltf/.vrm (hair, body, glasses, outfit
/// with the face; the same shapes as load_rig), an .obj as it is; posed by `pose` (rest_pose.hpp:
/// the rest pose by default). What every render path draws.
Rig load_scene(const std::filesystem::path& path, const Pose& pose = {});

}  // namespace facecast::rig
