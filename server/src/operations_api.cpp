#include "api.hpp"

#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "log.hpp"
#include "routes.hpp"

namespace facecast::server {

namespace fs = std::filesystem;

bool RigRegistry::remove(const std::string& id) {
  const fs::path dir = rigs_dir_ / id;
  // A name that start-up removes as a crash leftover (it contains ".tmp").
  const fs::path gone = rigs_dir_ / (id + ".tmp.deleted");
  {
    std::lock_guard lock(mutex_);
    sync(id);
    const auto it = infos_.find(id);
    if (it == infos_.end()) return false;
    if (it->second.builtin)
      throw RequestError(Code::kForbidden, "rig '" + id + "' is built in and cannot be deleted");
    std::error_code ec;
    fs::remove_all(gone, ec);
    fs::rename(dir, gone, ec);
    if (ec && fs::exists(dir))
      throw Error(dir.string() + ": cannot remove the rig: " + ec.message(), ErrorCode::kInternal);
    try {
      fsync_path(rigs_dir_);  // the rename is durable: after a crash the rig is gone or swept
    } catch (const Error& e) {
      log::warn("rig_delete_flush_failed", {{"rig", id}, {"error", e.what()}});
    }
    infos_.erase(it);
    loaded_.erase(id);
  }
  std::error_code ec;
  fs::remove_all(gone, ec);
  log::info("rig_deleted", {{"rig", id}, {"dir", dir.string()}});
  return true;
}

void RendererCache::drop(const std::string& id) {
  std::lock_guard lock(mutex_);
  std::erase_if(entries_, [&](const auto& e) { return std::get<0>(e.first) == id; });
}

http::message_generator RigApi::delete_rig(const Request& req, const std::string& id) {
  if (id == s_.options.default_rig)
    throw RequestError(Code::kForbidden,
                       "rig '" + id + "' is the server's default_rig and cannot be deleted");
  if (!s_.rigs.remove(id)) throw Error("rig '" + id + "' does not exist", ErrorCode::kNotFound);
  s_.rendering.renderers.drop(id);
  return reply_.json(req, http::status::ok, {{"deleted", id}});
}

http::message_generator delete_job(const Responses& reply, Jobs& jobs, const Request& req,
                                   const std::string& id) {
  if (!jobs.remove(id)) throw Error("job '" + id + "' does not exist", ErrorCode::kNotFound);
  return reply.json(req, http::status::ok, {{"deleted", id}});
}

}  // namespace facecast::server
