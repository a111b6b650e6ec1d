#pragma once
// The HTTP API of the rig builder and the renderer (docs/protocol.md): requests validated and
// answered at once (400/404/413), the work queued as jobs.
//  - POST /api/rigs (a rig build job, or a GLB/VRM imported as it is), PATCH and DELETE
//    /api/rigs/{id}, POST /api/landmarks, POST /api/render (a video job): api.cpp,
//    operations_api.cpp.
//  - An avatar from photos (rigbuild/photo_avatar.hpp): POST /api/photo {"front", "side"?,
//    "name"?} queues a "photo" job that builds the textured, speaking rig from the shipped
//    template (or configs/rigbuild/photo.json's) and stores it like a built rig; POST
//    /api/photo/landmarks {"photo"} answers the 68 points dlib finds, for a preview. Photos are
//    base64 JPEG/PNG or data URLs. Bad photos (no face, face too small) fail with a one-line
//    error and store nothing; several faces: the largest is used and a note says so
//    (photo_api.cpp).
#include <string>

#include <nlohmann/json.hpp>

#include "access.hpp"
#include "auth.hpp"
#include "beast.hpp"
#include "jobs.hpp"
#include "responses.hpp"
#include "routes.hpp"
#include "storage.hpp"
#include "stream_services.hpp"

namespace facecast::server {

class RigApi {
 public:
  /// Every argument outlives the RigApi (they are the server's services).
  RigApi(const StreamServices& services, Jobs& jobs, Storage& storage, const Access& access,
         const Responses& reply)
      : s_(services), jobs_(jobs), storage_(storage), access_(access), reply_(reply) {}

  /// POST /api/rigs: a JSON body builds a rig from a template (a job); a GLB/VRM body
  /// (Content-Type model/gltf-binary, model/vrm or application/octet-stream) imports an avatar
  /// as it is. The rig is `who`'s; ?public=1 (or "public": true in a JSON body) marks it public.
  http::message_generator post_rig(const Request& req, const Target& t, const Principal& who);
  /// PATCH /api/rigs/{id} {"public": true|false}: 200 with the rig's GET /api/rigs entry.
  http::message_generator patch_rig(const Request& req, const std::string& id);
  /// DELETE /api/rigs/{id}: 200 {"deleted": id}; 403 for the built-in rig and the server's
  /// default_rig; 404 when there is none.
  http::message_generator delete_rig(const Request& req, const std::string& id);
  /// POST /api/landmarks {"template": id, "mesh": {"format", "data"}}: a job that finds the
  /// facial landmarks on the mesh (rigbuild/landmarks.hpp); its result holds the marker pairs
  /// with the template ("markers", the --markers format), each landmark's target vertex
  /// ("target_vertices", null where dropped) and the views with the points found ("picture", a
  /// JPEG data URL).
  http::message_generator post_landmarks(const Request& req, const Principal& who);
  http::message_generator post_render(const Request& req, const Principal& who);
  http::message_generator post_photo(const Request& req, const std::string& tenant);
  http::message_generator post_photo_landmarks(const Request& req);

  /// The work of a queued job from its payload (the POST body) for `tenant` (who owns what it
  /// makes); throws Error like the POST does. With Redis, the instance that takes the job makes
  /// it here.
  Jobs::Work job_work(const std::string& kind, const nlohmann::json& payload,
                      const std::string& tenant);

 private:
  http::message_generator import_rig(const Request& req, const Target& t, const Principal& who);
  Jobs::Work rig_work(const nlohmann::json& body, const std::string& tenant);
  Jobs::Work render_work(const nlohmann::json& body);
  /// Throws Error naming the field.
  Jobs::Work photo_work(const nlohmann::json& body, const std::string& tenant);

  const StreamServices& s_;
  Jobs& jobs_;
  Storage& storage_;
  const Access& access_;
  const Responses& reply_;
};

/// DELETE /api/jobs/{id}: removes a job's record and files (cancelling it when it runs): 200
/// {"deleted": id}; 404.
http::message_generator delete_job(const Responses& reply, Jobs& jobs, const Request& req,
                                   const std::string& id);

/// Standard base64 (whitespace ignored, padding optional); throws Error naming `field`.
std::string base64_decode(std::string_view text, std::string_view field);

}  // namespace facecast::server
