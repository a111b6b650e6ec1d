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

}  // namespace facecast::server
