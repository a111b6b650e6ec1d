#pragma once
// What every connection shares (Beast chat-multi's shared_state): options, metrics, rigs,
// renderers, jobs, the worker pool, and the list of live sessions for shutdown.
#include <atomic>
#include <boost/asio/thread_pool.hpp>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <unordered_map>

#include "audio_uploads.hpp"
#include "auth.hpp"
#include "facecast/anim/animation.hpp"
#include "facecast/render/renderer.hpp"
#include "facecast/render/video.hpp"
#include "facecast/server/options.hpp"
#include "facecast/server/protocol.hpp"
#include "facecast/viseme/options.hpp"
#include "jobs.hpp"
#include "metrics.hpp"
#include "peer_limits.hpp"
#include "redis_bus.hpp"
#include "rigs.hpp"

namespace facecast::server {

/// A live connection the server can ask to close (from any thread).
class Closable {
 public:
  virtual ~Closable() = default;
  /// WebSockets: close with 1001 (going away); HTTP: close the socket.
  virtual void shut_down() = 0;
};

class ChannelRegistry;  // channel.hpp

/// Removes what a killed server left half-written (temporary files and folders: is_temp_name) in
/// the data folder, its rigs/, renders/ and tmp/, and, older than an hour (another instance may
/// be writing there now), in shared_dir's rigs/ and renders/. Logs one line; returns the count.
std::size_t sweep_leftovers(const ServerOptions& options);

struct State {
  explicit State(ServerOptions opts);

  ServerOptions options;
  Auth auth;  // keys, the old token and viewer tokens: who is calling (auth.hpp)
  std::filesystem::path web_root, three_root, three_vrm_root, client_root;  // resolved
  Metrics metrics;
  RigRegistry rigs;
  viseme::Options viseme_options;
  anim::AnimOptions anim_options;
  render::RenderOptions render_options;  // configs/render/render.json (camera, background, msaa)
  render::VideoOptions video_options;    // configs/render/render.json "video"
  RendererCache renderers;
  ProtocolLimits limits;
  AudioUploads audio_uploads;  // POST /api/audio, spoken by `speak` with audio_id
  ClientAddresses addresses;   // connections per client address
  BodyMemory body_memory;      // request body bytes held at once (max_body_memory)
  std::chrono::steady_clock::time_point started = std::chrono::steady_clock::now();
  std::atomic<bool> stopping{false};  // draining or shutting down: /readyz answers 503
  std::atomic<bool> ready{false};     // warmed up: /readyz answers 200
  std::atomic<std::uint64_t> next_connection{1};
  std::atomic<std::uint32_t> next_stream{1};
  std::atomic<long> connections{0};

  // Many instances: set when ServerOptions::redis.url is (redis_bus.hpp).
  std::unique_ptr<RedisBus> redis;
  // Short work: speech analysis, rendering, request bodies. Declared after everything it uses.
  boost::asio::thread_pool workers;
  Jobs jobs;
  // The configured channels; set by the server before any thread runs, dropped after they ended.
  std::shared_ptr<ChannelRegistry> channels;

  double uptime() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  }

  /// The rig `id` ("" for the default rig); throws Error (not found) naming it when there is none.
  RigInfo existing_rig(const std::string& id) const;

  void add_session(std::uint64_t id, std::weak_ptr<Closable> session);
  void remove_session(std::uint64_t id);
  std::size_t session_count();
  /// Asks every live session to close.
  void shut_down_sessions();

 private:
  std::mutex sessions_mutex_;
  std::unordered_map<std::uint64_t, std::weak_ptr<Closable>> sessions_;
};

}  // namespace facecast::server
