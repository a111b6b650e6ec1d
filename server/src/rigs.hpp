#pragma once
// The rigs a server knows: the built-in default avatar (id "default"), the shipped ICT FaceKit
// template (id "ict-facekit", rigbuild/template.hpp; served from its file) and the rigs built by
// jobs, stored under <data>/rigs/<id>/ (rig.glb, meta.json, virtual_edges.json, report.json; the
// folder is written under a temporary name and renamed, so a crash never leaves half a rig). Rigs
// are listed from meta.json at start-up and loaded (GLB parsed, mapping chosen) on first use.
// Renderers (GL contexts with the rig uploaded) are cached per rig and frame size.
#include <chrono>
#include <filesystem>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "facecast/anim/animation.hpp"
#include "facecast/render/renderer.hpp"
#include "facecast/render/video.hpp"
#include "facecast/rig/rest_pose.hpp"
#include "facecast/rig/rig.hpp"
#include "facecast/rigbuild/virtual_edges.hpp"

namespace facecast::server {

struct RigInfo {
  std::string id, name, template_id;
  std::vector<std::string> shapes;
  int vertices = 0;
  bool builtin = false;
  bool virtual_edges = false;
  bool imported = false;           // a user's avatar stored as it was uploaded
  double created = 0;              // Unix seconds
  std::string tenant = "default";  // whose rig (meta.json "tenant"; built-in rigs: nobody's)
  bool is_public = false;          // its GLB loads without a key (built-in rigs: always)
  nlohmann::json to_json() const;  // the GET /api/rigs entry
};

struct LoadedRig {
  std::string id;
  std::shared_ptr<const rig::Rig> rig;
  anim::Mapping mapping;
};

/// Who a stored rig belongs to (meta.json "tenant", "public").
struct RigOwner {
  std::string tenant = "default";
  bool is_public = false;
};

/// Rigs live in one folder that several instances may share: ids are random ("r" and 16 hex
/// digits), and a rig another instance stored or deleted is seen at the next lookup (no restart).
class RigRegistry {
 public:
  /// Creates <data>/rigs if needed and lists the stored rigs; `default_rig` is what "" resolves to.
  /// Uploads and stored rigs are read within `limits` (rig/decode_limits.hpp); loaded rigs stand
  /// in `pose` (rig/rest_pose.hpp).
  RigRegistry(std::filesystem::path data_dir, std::string default_rig,
              rig::DecodeLimits limits = {}, rig::Pose pose = {});

  std::vector<RigInfo> list() const;
  std::optional<RigInfo> find(const std::string& id) const;
  /// `id`, or the default rig for "".
  std::string resolve(const std::string& id) const;
  /// The rig `id` (resolved); throws Error (not found) naming it when there is none.
  RigInfo existing(const std::string& id) const;
  /// Parses and prepares a rig once; throws Error(kNotFound) for an unknown id.
  std::shared_ptr<const LoadedRig> load(const std::string& id);

  /// The stored GLB of a built rig or the shipped template (empty path for the built-in avatar).
  std::filesystem::path glb_path(const std::string& id) const;
  std::filesystem::path virtual_edges_path(const std::string& id) const;
  /// GLB bytes of the built-in avatar, made on first call.
  std::shared_ptr<const std::string> builtin_glb();

  /// Stores a built rig (`glb`: its file, rigbuild::BuildTarget::glb_bytes) and returns its new
  /// id.
  std::string add(const std::string& name, const std::string& template_id, const rig::Rig& rig,
                  const std::string& glb, const nlohmann::json& report,
                  const std::vector<rigbuild::VirtualEdge>& edges,
                  const rigbuild::VirtualEdgeStats& stats, const RigOwner& owner = {});
  /// Stores a user's avatar (GLB or VRM bytes) as it is, byte for byte, after checking that it
  /// parses and that the animation can drive it; throws Error naming `what` otherwise.
  std::string import(const std::string& name, const std::string& bytes, const std::string& what,
                     const RigOwner& owner = {});
  /// Marks a stored rig public or not (meta.json rewritten); false when there is no such rig;
  /// throws Error (forbidden) for a built-in rig.
  bool set_public(const std::string& id, bool is_public);
  /// Forgets a stored rig and removes its folder (renamed away first, so a crash never leaves
  /// half a rig); streams that hold it keep it until they end. False when there is no such rig;
  /// throws Error (forbidden) for the built-in rig. Defined in operations_api.cpp.
  bool remove(const std::string& id);

 private:
  std::filesystem::path rigs_dir_;
  std::string default_rig_;
  rig::DecodeLimits limits_;
  rig::Pose pose_;
  mutable std::mutex mutex_;
  mutable std::map<std::string, RigInfo> infos_;
  std::map<std::string, std::shared_future<std::shared_ptr<const LoadedRig>>> loaded_;
  // Writes `files` (name -> bytes), what `more` writes into the folder it is given, and meta.json
  // into <rigs>/<id> (a folder renamed into place).
  void store(const RigInfo& info, const std::vector<std::pair<std::string, std::string>>& files,
             const nlohmann::json& meta,
             const std::function<void(const std::filesystem::path&)>& more = {});
  std::string new_id();
  // Brings infos_ up to date with the folder of rig `id` (another instance may have stored or
  // removed it); mutex_ held.
  void sync(const std::string& id) const;
  void sync_all() const;
  // list() rescans the folder at most this often (a hello per WebSocket connection lists the
  // rigs: a burst of connections must not become a burst of folder scans).
  mutable std::chrono::steady_clock::time_point scanned_{};
  std::optional<RigInfo> read_folder(const std::filesystem::path& dir) const;
  std::shared_future<std::shared_ptr<const std::string>> builtin_glb_;
  bool builtin_glb_started_ = false;
};

/// Renderers per (rig, width, height), least recently used dropped beyond `capacity`.
class RendererCache {
 public:
  /// `base`: camera, background and MSAA of every renderer (configs/render/render.json).
  RendererCache(int capacity, int contexts, render::RenderOptions base)
      : capacity_(capacity), contexts_(contexts), base_(std::move(base)) {}
  /// Creates (and warms up: one GL context, one frame) on first use; thread-safe. At most
  /// `capacity` renderers exist at once: when every one is held by a playing or queued stream, a
  /// new (rig, size) is refused with RequestError (unavailable).
  std::shared_ptr<render::Renderer> get(const LoadedRig& rig, int width, int height);
  /// Drops the renderers of rig `id` (after DELETE; defined in operations_api.cpp).
  void drop(const std::string& id);

 private:
  struct Entry {
    std::shared_future<std::shared_ptr<render::Renderer>> renderer;
    unsigned long long used = 0;
  };
  static bool in_use(const Entry& e);

  int capacity_, contexts_;
  render::RenderOptions base_;
  std::mutex mutex_;
  std::map<std::tuple<std::string, int, int>, Entry> entries_;
  unsigned long long clock_ = 0;
};

/// Everything the server draws with: the settings of every render and video
/// (configs/render/render.json) and the renderers of streams and channels.
struct Rendering {
  Rendering(int max_renderers, int contexts)
      : options(render::load_render_options()),
        video(render::load_video_options()),
        renderers(max_renderers, contexts, options) {}

  const render::RenderOptions options;  // camera, background, MSAA
  const render::VideoOptions video;     // the "video" section: ffmpeg, encoder
  RendererCache renderers;
};

}  // namespace facecast::server
