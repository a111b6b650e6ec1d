#pragma once
// Reading glTF accessors into Eigen matrices: any component type (normalized integers as glTF
// defines them, KHR_mesh_quantization), byte strides, sparse substitutions. Every index and extent
// is checked before anything is read or allocated.
#include <tiny_gltf.h>

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "decode_budget.hpp"

namespace facecast::rig::detail {

using FloatRows = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// The accessor `index` as `comps` floats per element (the accessor must have that many
/// components); integers are normalized when the accessor says so, converted as they are
/// otherwise. `what` names it in errors. What it allocates is charged to `budget` first.
FloatRows read_floats(const tinygltf::Model& m, int index, int comps, const std::string& what,
                      DecodeBudget* budget = nullptr);

/// The accessor as unsigned integers (indices, JOINTS_n), `comps` per element.
std::vector<std::uint32_t> read_uints(const tinygltf::Model& m, int index, int comps,
                                      const std::string& what, DecodeBudget* budget = nullptr);

/// The accessor, checked to exist.
const tinygltf::Accessor& accessor_at(const tinygltf::Model& m, int index, const std::string& what);

}  // namespace facecast::rig::detail
