#pragma once
// A glTF container opened for packing (gltf_package.cpp): a GLB split into its JSON and BIN
// chunks, or .gltf text, with the JSON's nesting, value count and object counts checked against
// the limits before tinygltf or the packer spend anything on it.
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "facecast/rig/decode_limits.hpp"

namespace facecast::rig::detail {

struct Container {
  nlohmann::json doc;
  std::string bin;  // the GLB's BIN chunk (empty for .gltf text)
  bool glb = false;
};

/// Splits a GLB (or takes .gltf text), checks the JSON's depth and value count, then parses it.
/// Error naming `what` for a truncated or malformed container.
Container split_container(std::string_view bytes, const std::string& what,
                          const DecodeLimits& limits);

/// Counts of glTF objects (nodes, meshes, accessors, primitives, morph targets, joints, ...)
/// against `limits`: Error (kLimit) naming the field and the limit's key.
void check_counts(nlohmann::json& doc, const std::string& what, const DecodeLimits& limits);

/// A JSON array member (empty when absent); anything else is an error naming the key.
nlohmann::json& array_of(nlohmann::json& o, const char* key, const std::string& what);

}  // namespace facecast::rig::detail
