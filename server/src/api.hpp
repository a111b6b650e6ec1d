#pragma once
// POST /api/rigs (rig build job) and POST /api/render (video render job): request validation
// (answered at once with 400/404/413) and the job work.
#include "auth.hpp"
#include "beast.hpp"
#include "routes.hpp"
#include "state.hpp"

namespace facecast::server {

/// POST /api/rigs: a JSON body builds a rig from a template (a job); a GLB/VRM body
/// (Content-Type model/gltf-binary, model/vrm or application/octet-stream) imports an avatar as it
/// is. The rig is `who`'s; ?public=1 (or "public": true in a JSON body) marks it public.
http::message_generator post_rig(State& state, const Request& req, const Target& t,
                                 const Principal& who);
http::message_generator post_render(State& state, const Request& req, const Principal& who);
/// POST /api/landmarks {"template": id, "mesh": {"format", "data"}}: a job that finds the facial
/// landmarks on the mesh (rigbuild/landmarks.hpp); its result holds the marker pairs with the
/// template ("markers", the --markers format), each landmark's target vertex ("target_vertices",
/// null where dropped) and the views with the points found ("picture", a JPEG data URL).
http::message_generator post_landmarks(State& state, const Request& req, const Principal& who);
/// PATCH /api/rigs/{id} {"public": true|false}: 200 with the rig's GET /api/rigs entry.
http::message_generator patch_rig(State& state, const Request& req, const std::string& id);

/// The work of a queued job from its payload (the POST body) for `tenant` (who owns what it
/// makes); throws Error like the POST does. With Redis, the instance that takes the job makes it
/// here.
Jobs::Work job_work(State& state, const std::string& kind, const nlohmann::json& payload,
                    const std::string& tenant);

/// Standard base64 (whitespace ignored, padding optional); throws Error naming `field`.
std::string base64_decode(std::string_view text, std::string_view field);

}  // namespace facecast::server
