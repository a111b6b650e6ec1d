#pragma once
// Pictures of a rig for people: the mesh shaded in grey with virtual edges or crossing triangles
// drawn over it, front and side views of the face, rasterized on the CPU (no GL needed) and
// written as PNG (to a temporary file, then renamed).
#include <filesystem>
#include <utility>
#include <vector>

#include "facecast/rig/rig.hpp"
#include "facecast/rigbuild/transfer.hpp"

namespace facecast::rigbuild {

struct PictureOptions {
  int size = 768;           // height of each view in pixels
  bool see_through = true;  // draw every edge, also those hidden behind the surface (dimmer)
};

/// Two views (front, right side) of `positions` with `edges` in red, side by side.
void write_virtual_edge_picture(const std::filesystem::path& png, const rig::Rig& rig,
                                const rig::Positions& positions,
                                const std::vector<VirtualEdge>& edges,
                                const PictureOptions& options = {});

/// Two views of `positions` (a posed shape) with the triangles of `pairs` (e.g. a shape's new
/// intersecting pairs) in red, and in pale red through the surface where hidden.
void write_crossing_picture(const std::filesystem::path& png, const rig::Rig& rig,
                            const rig::Positions& positions,
                            const std::vector<std::pair<int, int>>& pairs,
                            const PictureOptions& options = {});

}  // namespace facecast::rigbuild
