#pragma once
// The Rig as a view of an avatar document (avatar_document.hpp): the document's primitives merged
// in the bind pose (node world transforms applied, skinned meshes skinned to the rest pose the
// file's nodes hold), morph targets merged by name across primitives, materials, textures and the
// skeleton; with a map from every merged vertex back to (mesh, primitive, vertex) so that new or
// changed shapes go back where they belong.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "facecast/rig/avatar_document.hpp"
#include "facecast/rig/rig.hpp"

namespace facecast::rig {

struct ViewOptions {
  /// false: the face the animation drives and the rig builder gives shapes to: the primitives of
  /// meshes with morph targets; when none has any, the meshes the skeleton's head joint carries
  /// (under it, or skinned mostly to it and the joints under it), or every mesh without a head
  /// joint. true: every triangle mesh (hair, body, clothes too), for rendering.
  bool all_meshes = false;
};

/// One drawn primitive of the view: a mesh primitive under a node.
struct ViewPart {
  int node = -1, mesh = -1, primitive = -1;
  std::string mesh_name;
  int first_vertex = 0, vertex_count = 0;  // rows of the rig
  int position_accessor = -1;              // primitives sharing it share vertices
  bool skinned = false;
  bool owner = true;  // false when another part already holds these vertices
};

/// A mesh of the document with morph targets, as `rig info` lists it.
struct ViewMesh {
  int mesh = -1;
  std::string name;
  int vertices = 0;  // rig rows from this mesh
  std::vector<std::string> targets;
};

struct AvatarView {
  Rig rig;
  std::vector<ViewPart> parts;
  std::vector<ViewMesh> meshes;
  /// Per rig vertex: the rig-from-file linear map (node transform or skinning at rest) that
  /// deltas went through; write_back uses its inverse.
  std::vector<Eigen::Matrix3f> to_rig;
  /// Shapes made from VRM expressions (combinations of morph targets); never written back.
  std::vector<std::string> derived_shapes;
};

/// Builds the view of `doc`. Throws facecast::Error naming the document and the field when the
/// file is malformed or holds no triangles.
AvatarView make_view(const AvatarDocument& doc, const ViewOptions& options = {});

/// Writes `rig`'s shapes (same vertices as view.rig) back into the document: a shape that exists
/// in a mesh's targets is replaced when its deltas changed, a new shape is appended to every mesh
/// it moves (all primitives of that mesh, targetNames and default weights updated). Everything
/// else in the document is left as it is.
void write_back(AvatarDocument& doc, const AvatarView& view, const Rig& rig);

/// Head and neck joints by name: Head/Neck, J_Bip_C_Head/J_Bip_C_Neck, mixamorig:Head, ...
/// (case-insensitive, prefixes before ':' ignored); -1 when absent.
int find_joint(const std::vector<std::string>& names, const char* role);

}  // namespace facecast::rig
