#pragma once
// An avatar from photos over HTTP (rigbuild/photo_avatar.hpp, docs/protocol.md):
// POST /api/photo {"front", "side"?, "name"?} queues a "photo" job that builds the textured,
// speaking rig from the shipped template (or configs/rigbuild/photo.json's) and stores it like a
// built rig; POST /api/photo/landmarks {"photo"} answers the 68 points dlib finds, for a preview.
// Photos are base64 JPEG/PNG or data URLs. Bad photos (no face, face too small) fail with a
// one-line error and store nothing; several faces: the largest is used and a note says so.
#include <nlohmann/json.hpp>

#include "beast.hpp"
#include "jobs.hpp"
#include "state.hpp"

namespace facecast::server {

http::message_generator post_photo(State& state, const Request& req, const std::string& tenant);
http::message_generator post_photo_landmarks(State& state, const Request& req);

/// The photo job's work from its payload (the POST body); throws Error naming the field.
Jobs::Work photo_work(State& state, const nlohmann::json& body, const std::string& tenant);

}  // namespace facecast::server
