#pragma once
// DELETE /api/rigs/{id} and DELETE /api/jobs/{id} (docs/protocol.md, "HTTP API").
#include <string>

#include "beast.hpp"
#include "state.hpp"

namespace facecast::server {

/// Removes a stored rig: 200 {"deleted": id}; 403 for the built-in rig and the server's
/// default_rig; 404 when there is none.
http::message_generator delete_rig(State& state, const Request& req, const std::string& id);
/// Removes a job's record and files (cancelling it when it runs): 200 {"deleted": id}; 404.
http::message_generator delete_job(State& state, const Request& req, const std::string& id);

}  // namespace facecast::server
