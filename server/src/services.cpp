#include "services.hpp"

#include "facecast/core/config.hpp"
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

WebRoots::WebRoots(const ServerOptions& o)
    : web(project_path(o.web_root)),
      three(project_path(o.three_root)),
      three_vrm(project_path(o.three_vrm_root)),
      client(project_path(o.client_root)) {}

Services::Services(ServerOptions opts)
    : options(std::move(opts)),
      responses(options, metrics),
      auth(options),
      web(options),
      rigs(options.shared_dir.empty() ? options.data : options.shared_dir, options.default_rig,
           options.decode, options.pose),
      rendering(options.max_renderers, options.render_contexts),
      speech(rigs, rendering.renderers, metrics,
             AudioUploadOptions{options.data / "tmp", options.max_audio_seconds,
                                options.audio_decode_timeout},
             options.max_utterance_seconds),
      limits{options.max_text, options.max_fps, options.max_frame_side, options.max_json_depth},
      addresses(options.max_connections_per_address, options.trusted_proxies),
      body_memory(options.max_body_memory),
      redis(options.redis.url.empty() ? nullptr : std::make_unique<RedisBus>(options)),
      workers(static_cast<std::size_t>(options.workers)),
      streams{options, metrics, sessions, rigs, rendering, speech, workers, redis.get()},
      jobs(metrics, JobsOptions{options.job_workers, options.max_jobs,
                                options.data / "jobs.sqlite3", options.job_retention, redis.get()}),
      storage(options, rigs, jobs),
      access(auth, rigs, speech.uploads(), channels, responses),
      rig_api(streams, jobs, storage, access, responses) {}

}  // namespace facecast::server
