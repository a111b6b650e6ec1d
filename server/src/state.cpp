#include "state.hpp"

#include "facecast/core/config.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "log.hpp"

namespace facecast::server {
namespace {

std::filesystem::path project_path(const std::filesystem::path& p) {
  if (p.is_absolute()) return p;
  return config_dir().parent_path() / p;
}

}  // namespace

std::size_t sweep_leftovers(const ServerOptions& o) {
  constexpr double kSharedAge = 3600;  // seconds: older temporaries in shared_dir are leftovers
  std::size_t count = 0;
  for (const char* sub : {"", "rigs", "renders", "tmp"}) count += sweep_temp_files(o.data / sub);
  if (!o.shared_dir.empty())
    for (const char* sub : {"rigs", "renders"})
      count += sweep_temp_files(o.shared_dir / sub, kSharedAge);
  if (count > 0) log::info("temp_swept", {{"count", count}, {"data", o.data.string()}});
  return count;
}

State::State(ServerOptions opts)
    : options(std::move(opts)),
      auth(options),
      web_root(project_path(options.web_root)),
      three_root(project_path(options.three_root)),
      three_vrm_root(project_path(options.three_vrm_root)),
      client_root(project_path(options.client_root)),
      rigs(options.shared_dir.empty() ? options.data : options.shared_dir, options.default_rig,
           options.decode, options.pose),
      viseme_options(viseme::load_options()),
      anim_options(anim::load_anim_options()),
      render_options(render::load_render_options()),
      video_options(render::load_video_options()),
      renderers(options.max_renderers, options.render_contexts, render_options),
      limits{options.max_text, options.max_fps, options.max_frame_side, options.max_json_depth},
      audio_uploads(AudioUploadOptions{options.data / "tmp", options.max_audio_seconds,
                                       options.audio_decode_timeout}),
      addresses(options.max_connections_per_address, options.trusted_proxies),
      body_memory(options.max_body_memory),
      redis(options.redis.url.empty() ? nullptr : std::make_unique<RedisBus>(options)),
      workers(static_cast<std::size_t>(options.workers)),
      jobs(metrics,
           JobsOptions{options.job_workers, options.max_jobs, options.data / "jobs.sqlite3",
                       options.job_retention, redis.get()}) {}

RigInfo State::existing_rig(const std::string& id) const {
  const std::string rig = rigs.resolve(id);
  auto info = rigs.find(rig);
  if (!info) throw Error("rig '" + rig + "' does not exist", ErrorCode::kNotFound);
  return std::move(*info);
}

void State::add_session(std::uint64_t id, std::weak_ptr<Closable> session) {
  std::lock_guard lock(sessions_mutex_);
  sessions_[id] = std::move(session);
}

void State::remove_session(std::uint64_t id) {
  std::lock_guard lock(sessions_mutex_);
  sessions_.erase(id);
}

std::size_t State::session_count() {
  std::lock_guard lock(sessions_mutex_);
  return sessions_.size();
}

void State::shut_down_sessions() {
  std::vector<std::shared_ptr<Closable>> live;
  {
    std::lock_guard lock(sessions_mutex_);
    for (auto& [id, weak] : sessions_)
      if (auto s = weak.lock()) live.push_back(std::move(s));
  }
  for (auto& s : live) s->shut_down();
}

}  // namespace facecast::server
