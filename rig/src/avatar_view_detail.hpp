#pragma once
// Shared between the view's files: node world transforms and the pieces of the view that are not
// geometry (materials, textures, skeleton, VRM expressions).
#include <tiny_gltf.h>

#include <Eigen/Geometry>
#include <map>
#include <string>
#include <vector>

#include "facecast/rig/avatar_view.hpp"

namespace facecast::rig::detail {

/// World transforms of every node (identity for nodes in no scene) and each node's parent (-1).
/// The nodes' world transforms in the rig's frame: as the file has them, except that a VRM 0.x
/// figure (which faces -Z) is turned half about +Y to face +Z as every other avatar does.
struct NodeGraph {
  std::vector<Eigen::Matrix4f> world;
  std::vector<int> parent;
  std::vector<int> order;  // nodes of the scene, depth first
};
NodeGraph node_graph(const tinygltf::Model& m, const std::string& what);

/// Materials and textures of the document into the rig (indices kept).
void read_materials(const tinygltf::Model& m, Rig& rig);

/// The skeleton over `joint_nodes` (node indices, in order), with head and neck found and the
/// spring bones read.
Skeleton read_skeleton(const tinygltf::Model& m, const NodeGraph& g,
                       const std::vector<int>& joint_nodes);

/// The spring bones of VRMC_springBone (VRM 1.0) or VRM 0.x's secondaryAnimation over the
/// skeleton whose joints `joint_of_node` maps from nodes (avatar_view_springs.cpp). Throws Error
/// naming the extension past the limits there.
SpringBones read_springs(const tinygltf::Model& m, const NodeGraph& g,
                         const std::map<int, int>& joint_of_node);

/// o[key] when it is a finite number (clamped to +-1e4), else `fallback`.
float number_or(const tinygltf::Value& o, const char* key, float fallback);

/// A VRM expression: its name (VRM 1.0 preset naming) and (mesh, target index, weight) binds.
struct Expression {
  std::string name;
  struct Bind {
    int mesh, target;
    float weight;
  };
  std::vector<Bind> binds;
};
/// VRM 0.x blendShapeGroups or VRM 1.0 expressions; empty for other files.
std::vector<Expression> vrm_expressions(const tinygltf::Model& m);

}  // namespace facecast::rig::detail
