// The humanoid with a ponytail as a file (spring_avatar.hpp).
#include "spring_avatar.hpp"

#include "facecast/rig/avatar_document.hpp"
#include "facecast/rig/rig_io.hpp"
#include "humanoid.hpp"

namespace facecast::test {
using tinygltf::Value;

std::string ponytail_glb(bool front,
                         const std::function<void(tinygltf::Model&, const NodeOf&)>& edit) {
  rig::Rig figure = humanoid(0);
  add_ponytail(figure, front);
  rig::AvatarDocument doc = rig::AvatarDocument::parse(rig::glb_bytes(figure), "ponytail.glb");
  tinygltf::Model& m = doc.model();
  edit(m, [&m](const std::string& joint) {
    for (std::size_t i = 0; i < m.nodes.size(); ++i)
      if (m.nodes[i].name == joint) return static_cast<int>(i);
    throw std::runtime_error("ponytail_glb: no node " + joint);
  });
  return doc.glb_bytes();
}

std::string ponytail_vrm(bool front, bool springs, double gravity_x) {
  return ponytail_glb(front, [springs, gravity_x](tinygltf::Model& m, const NodeOf& node) {
    if (!springs) return;
    Value::Array joints;
    for (const char* j : {"Hair1", "Hair2", "Hair3"})
      joints.push_back(object({{"node", Value(node(j))},
                               {"stiffness", Value(1.0)},
                               {"dragForce", Value(0.4)},
                               {"hitRadius", Value(0.02)},
                               {"gravityPower", Value(gravity_x)},
                               {"gravityDir", array_of({1.0, 0.0, 0.0})}}));
    const Value sphere = object({{"offset", array_of({0.0, 0.05, 0.0})}, {"radius", Value(0.1)}});
    const Value collider =
        object({{"node", Value(node("mixamorig:Head"))}, {"shape", object({{"sphere", sphere}})}});
    const Value group = object({{"colliders", array_of({0})}});
    const Value spring = object({{"joints", Value(joints)}, {"colliderGroups", array_of({0})}});
    m.extensions["VRMC_springBone"] = object({{"specVersion", Value(std::string("1.0"))},
                                              {"colliders", Value(Value::Array{collider})},
                                              {"colliderGroups", Value(Value::Array{group})},
                                              {"springs", Value(Value::Array{spring})}});
    m.extensionsUsed.push_back("VRMC_springBone");
  });
}

}  // namespace facecast::test
