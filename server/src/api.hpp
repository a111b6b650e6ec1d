#pragma once
// POST /api/rigs (rig build job) and POST /api/render (video render job): request validation
// (answered at once with 400/404/413) and the job work.
#include "beast.hpp"
#include "state.hpp"

namespace facecast::server {

http::message_generator post_rig(State& state, const Request& req);
http::message_generator post_render(State& state, const Request& req);

/// Standard base64 (whitespace ignored, padding optional); throws Error naming `field`.
std::string base64_decode(std::string_view text, std::string_view field);

/// When `target` has the template's triangles in another order (a GLB groups them by
/// material), reorders them (and their materials/groups) to the template's order. Returns true if
/// the two meshes share their triangles.
bool match_triangle_order(const anim::Rig& tmpl, anim::Rig& target);

}  // namespace facecast::server
