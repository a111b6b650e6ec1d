#pragma once
// The code-made humanoid with a ponytail (humanoid.hpp) as a file, with its spring bones written as
// VRM files hold them.
#include <tiny_gltf.h>

#include <functional>
#include <string>

namespace facecast::test {

/// JSON values for extensions written in code.
inline tinygltf::Value object(
    std::initializer_list<std::pair<const std::string, tinygltf::Value>> members) {
  return tinygltf::Value(tinygltf::Value::Object(members));
}
template <class T>
tinygltf::Value array_of(std::initializer_list<T> xs) {
  tinygltf::Value::Array a;
  for (const T x : xs) a.push_back(tinygltf::Value(x));
  return tinygltf::Value(a);
}

/// Gives a joint's node in the written document.
using NodeOf = std::function<int(const std::string& joint)>;

/// The humanoid with its ponytail (`front`: in front of the face) as GLB bytes, the document edited
/// by `edit` first.
std::string ponytail_glb(bool front,
                         const std::function<void(tinygltf::Model&, const NodeOf&)>& edit);

/// The same as a VRM 1.0 file whose VRMC_springBone holds the ponytail's spring (Hair1 -> Hair2 ->
/// Hair3: stiffness 1, drag 0.4, hit radius 0.02, gravity `gravity_x` along +X) and a sphere
/// collider on the head (offset
/// (0, 0.05, 0), radius 0.1) ; `springs` false: the same
/// file without the extension.
std::string ponytail_vrm(bool front = false, bool springs = true, double gravity_x = 0);

}  // namespace facecast::test
