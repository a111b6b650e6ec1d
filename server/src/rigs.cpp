#include "rigs.hpp"

#include <chrono>
#include <regex>

#include "clock.hpp"
#include "facecast/avatar/avatar.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/core/random.hpp"
#include "facecast/rig/avatar_view.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/rigbuild/build.hpp"
#include "facecast/rigbuild/template.hpp"
#include "facecast/server/protocol.hpp"
#include "log.hpp"

namespace facecast::server {
namespace {

namespace fs = std::filesystem;
constexpr const char* kBuiltin = "default";

RigInfo builtin_info() {
  RigInfo i;
  i.id = kBuiltin;
  i.name = "Default avatar";
  i.template_id = "";
  i.shapes = avatar::avatar_shape_names();
  i.vertices = avatar::default_avatar().vertex_count();
  i.builtin = true;
  i.tenant.clear();
  i.is_public = true;
  return i;
}

// The shipped realistic template (rigbuild/template.hpp), read from its file when served.
RigInfo shipped_info() {
  const rigbuild::TemplateSummary summary = rigbuild::shipped_template_summary();
  RigInfo i;
  i.id = rigbuild::kShippedTemplateId;
  i.name = "ICT FaceKit (realistic template)";
  i.shapes = summary.shapes;
  i.vertices = summary.vertices;
  i.builtin = true;
  i.tenant.clear();
  i.is_public = true;
  return i;
}

RigInfo info_from_meta(const nlohmann::json& j) {
  RigInfo i;
  i.id = j.at("id").get<std::string>();
  i.name = j.at("name").get<std::string>();
  i.template_id = j.value("template", "");
  i.shapes = j.at("shapes").get<std::vector<std::string>>();
  i.vertices = j.at("vertices").get<int>();
  i.virtual_edges = j.value("virtual_edges", false);
  i.imported = j.value("imported", false);
  i.created = j.value("created", 0.0);
  i.tenant = j.value("tenant", "default");  // rigs stored before tenants: the default one's
  i.is_public = j.value("public", false);
  return i;
}

}  // namespace

nlohmann::json RigInfo::to_json() const {
  nlohmann::json j = {{"id", id},           {"name", name},
                      {"shapes", shapes},   {"vertices", vertices},
                      {"builtin", builtin}, {"url", "/api/rigs/" + id + ".glb"},
                      {"public", is_public}};
  if (!builtin) {
    j["tenant"] = tenant;
    j["template"] = template_id;
    j["created"] = created;
    j["virtual_edges"] = virtual_edges;
    j["imported"] = imported;
  }
  return j;
}

RigRegistry::RigRegistry(fs::path data_dir, std::string default_rig, rig::DecodeLimits limits,
                         rig::Pose pose)
    : rigs_dir_(std::move(data_dir) / "rigs"),
      default_rig_(std::move(default_rig)),
      limits_(limits),
      pose_(std::move(pose)) {
  std::error_code ec;
  fs::create_directories(rigs_dir_, ec);
  if (ec)
    throw Error(rigs_dir_.string() + ": cannot create the data folder: " + ec.message(),
                ErrorCode::kInternal);
  infos_[kBuiltin] = builtin_info();
  try {
    infos_[rigbuild::kShippedTemplateId] = shipped_info();
  } catch (const std::exception& e) {  // an install without it still serves the default avatar
    log::warn("shipped_template_missing", {{"error", e.what()}});
  }
  // Crash leftovers (".tmp" folders) were swept by the server at start (sweep_leftovers).
  sync_all();
  if (!infos_.contains(default_rig_))
    throw Error("default_rig: no rig '" + default_rig_ + "' in " + rigs_dir_.string(),
                ErrorCode::kNotFound);
  log::info("rigs_listed", {{"dir", rigs_dir_.string()}, {"count", infos_.size()}});
}

namespace {

bool is_rig_id(const std::string& name) {
  static const std::regex id_re("r[0-9a-f]{1,32}");
  return std::regex_match(name, id_re);
}

}  // namespace

std::optional<RigInfo> RigRegistry::read_folder(const fs::path& dir) const {
  try {
    const RigInfo info = info_from_meta(load_json(dir / "meta.json"));
    if (info.id != dir.filename().string())
      throw Error("meta.json: id '" + info.id + "' differs from the folder");
    if (!fs::exists(dir / "rig.glb")) throw Error("rig.glb is missing");
    return info;
  } catch (const std::exception& e) {
    log::warn("rig_skipped", {{"dir", dir.string()}, {"error", e.what()}});
    return std::nullopt;
  }
}

void RigRegistry::sync(const std::string& id) const {
  if (id == kBuiltin || !is_rig_id(id)) return;
  const fs::path dir = rigs_dir_ / id;
  std::error_code ec;
  const bool there = fs::exists(dir / "meta.json", ec);
  if (there && !infos_.contains(id)) {
    if (auto info = read_folder(dir)) infos_[id] = std::move(*info);
  } else if (!there && infos_.contains(id)) {
    infos_.erase(id);  // removed by another instance
  }
}

void RigRegistry::sync_all() const {
  std::error_code ec;
  std::vector<std::string> seen;
  for (const auto& entry : fs::directory_iterator(rigs_dir_, ec)) {
    const std::string name = entry.path().filename().string();
    if (!is_rig_id(name)) continue;
    seen.push_back(name);
    if (!infos_.contains(name)) sync(name);
  }
  if (ec) return;  // the folder cannot be read now: keep what is known
  std::erase_if(infos_, [&](const auto& e) {
    return !e.second.builtin && std::find(seen.begin(), seen.end(), e.first) == seen.end();
  });
}

std::vector<RigInfo> RigRegistry::list() const {
  std::lock_guard lock(mutex_);
  const auto now = std::chrono::steady_clock::now();
  if (now - scanned_ > std::chrono::seconds(1)) {
    sync_all();
    scanned_ = now;
  }
  std::vector<RigInfo> out;
  out.push_back(infos_.at(kBuiltin));
  for (const auto& [id, info] : infos_)
    if (id != kBuiltin && info.builtin) out.push_back(info);
  for (const auto& [id, info] : infos_)
    if (!info.builtin) out.push_back(info);
  return out;
}

std::optional<RigInfo> RigRegistry::find(const std::string& id) const {
  std::lock_guard lock(mutex_);
  sync(id);
  const auto it = infos_.find(id);
  if (it == infos_.end()) return std::nullopt;
  return it->second;
}

RigInfo RigRegistry::existing(const std::string& id) const {
  const std::string rig = resolve(id);
  auto info = find(rig);
  if (!info) throw Error("rig '" + rig + "' does not exist", ErrorCode::kNotFound);
  return std::move(*info);
}

std::string RigRegistry::resolve(const std::string& id) const {
  return id.empty() ? default_rig_ : id;
}

std::shared_ptr<const LoadedRig> RigRegistry::load(const std::string& requested) {
  const std::string id = resolve(requested);
  std::promise<std::shared_ptr<const LoadedRig>> promise;
  std::shared_future<std::shared_ptr<const LoadedRig>> future;
  bool loader = false;
  {
    std::lock_guard lock(mutex_);
    sync(id);
    if (!infos_.contains(id)) throw Error("rig '" + id + "' does not exist", ErrorCode::kNotFound);
    const auto it = loaded_.find(id);
    if (it != loaded_.end()) {
      future = it->second;
    } else {
      future = promise.get_future().share();
      loaded_[id] = future;
      loader = true;
    }
  }
  if (!loader) return future.get();  // rethrows the loader's error
  try {
    auto loaded = std::make_shared<LoadedRig>();
    loaded->id = id;
    {
      const auto t0 = std::chrono::steady_clock::now();
      // Every mesh (hair, body, clothes too): the frames show the whole avatar. The built-in one
      // goes through its GLB too, as users' files do.
      rig::AvatarDocument doc = id == kBuiltin
                                    ? rig::AvatarDocument::parse(*builtin_glb(), "builtin.glb")
                                    : rig::AvatarDocument::read(glb_path(id), limits_);
      // Standing as configured: in the rest pose an avatar saved in T-pose puts its arms down.
      rig::Rig scene = rig::make_view(doc, {.all_meshes = true}).rig;
      const rig::PoseReport posed = rig::apply_pose(scene, pose_);
      loaded->rig = std::make_shared<const rig::Rig>(std::move(scene));
      log::info(
          "rig_loaded",
          {{"rig", id},
           {"bones_turned", posed.turned.size()},
           {"ms", std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                      .count()}});
    }
    loaded->mapping = anim::Mapping::for_rig(loaded->rig->shape_names());
    std::shared_ptr<const LoadedRig> result = std::move(loaded);
    promise.set_value(result);
    return result;
  } catch (...) {
    promise.set_exception(std::current_exception());
    std::lock_guard lock(mutex_);
    loaded_.erase(id);  // let a later request try again
    throw;
  }
}

fs::path RigRegistry::glb_path(const std::string& id) const {
  if (id == kBuiltin) return {};
  if (id == rigbuild::kShippedTemplateId) return rigbuild::shipped_template_path();
  return rigs_dir_ / id / "rig.glb";
}

fs::path RigRegistry::virtual_edges_path(const std::string& id) const {
  if (id == kBuiltin || id == rigbuild::kShippedTemplateId) return {};
  return rigs_dir_ / id / "virtual_edges.json";
}

std::shared_ptr<const std::string> RigRegistry::builtin_glb() {
  std::promise<std::shared_ptr<const std::string>> promise;
  bool loader = false;
  std::shared_future<std::shared_ptr<const std::string>> future;
  {
    std::lock_guard lock(mutex_);
    if (!builtin_glb_started_) {
      builtin_glb_ = promise.get_future().share();
      builtin_glb_started_ = true;
      loader = true;
    }
    future = builtin_glb_;
  }
  if (loader) {
    try {
      promise.set_value(
          std::make_shared<const std::string>(rig::glb_bytes(avatar::default_avatar())));
    } catch (...) {
      promise.set_exception(std::current_exception());
      std::lock_guard lock(mutex_);
      builtin_glb_started_ = false;
    }
  }
  return future.get();
}

std::string RigRegistry::new_id() {
  return "r" + random_hex(8);  // 64 bits from the kernel (core/random.hpp)
}

void RigRegistry::store(const RigInfo& info,
                        const std::vector<std::pair<std::string, std::string>>& files,
                        const nlohmann::json& meta,
                        const std::function<void(const fs::path&)>& more) {
  // Everything goes into a temporary folder that is renamed into place at the end.
  const fs::path tmp = rigs_dir_ / (info.id + ".tmp");
  const fs::path dir = rigs_dir_ / info.id;
  std::error_code ec;
  fs::remove_all(tmp, ec);
  try {
    fs::create_directories(tmp);
    for (const auto& [file, bytes] : files) write_file_atomic(tmp / file, bytes);
    if (more) more(tmp);
    write_file_atomic(tmp / "meta.json", meta.dump(2) + "\n");
    commit_file(tmp, dir);  // its files were flushed; the folder, the rename and rigs/ are too
  } catch (const fs::filesystem_error& e) {
    fs::remove_all(tmp, ec);
    throw Error(dir.string() + ": cannot store the rig: " + e.code().message(),
                ErrorCode::kInternal);
  } catch (...) {
    fs::remove_all(tmp, ec);
    throw;
  }
  {
    std::lock_guard lock(mutex_);
    infos_[info.id] = info;
  }
  log::info("rig_stored", {{"rig", info.id}, {"name", info.name}, {"dir", dir.string()}});
}

std::string RigRegistry::add(const std::string& name, const std::string& template_id,
                             const rig::Rig& rig, const std::string& glb,
                             const nlohmann::json& report,
                             const std::vector<rigbuild::VirtualEdge>& edges,
                             const rigbuild::VirtualEdgeStats& stats, const RigOwner& owner) {
  RigInfo info;
  info.tenant = owner.tenant;
  info.is_public = owner.is_public;
  info.id = new_id();
  info.name = name;
  info.template_id = template_id;
  info.shapes = rig.shape_names();
  info.vertices = rig.vertex_count();
  info.virtual_edges = !edges.empty();
  info.created = unix_now();
  store(info, {{"rig.glb", glb}, {"report.json", report.dump(2) + "\n"}},
        {{"id", info.id},
         {"name", name},
         {"template", template_id},
         {"shapes", info.shapes},
         {"vertices", info.vertices},
         {"virtual_edges", info.virtual_edges},
         {"created", info.created},
         {"tenant", info.tenant},
         {"public", info.is_public}},
        [&](const fs::path& dir) {
          if (!edges.empty())
            rigbuild::write_virtual_edges_json(dir / "virtual_edges.json", edges, stats);
        });
  return info.id;
}

std::string RigRegistry::import(const std::string& name, const std::string& bytes,
                                const std::string& what, const RigOwner& owner) {
  const rig::AvatarView view = rig::make_view(rig::AvatarDocument::parse(bytes, what, limits_));
  anim::Mapping::for_rig(view.rig.shape_names());  // throws when nothing maps: not a face rig
  RigInfo info;
  info.id = new_id();
  info.name = name;
  info.shapes = view.rig.shape_names();
  info.vertices = view.rig.vertex_count();
  info.imported = true;
  info.created = unix_now();
  info.tenant = owner.tenant;
  info.is_public = owner.is_public;
  store(info, {{"rig.glb", bytes}},
        {{"id", info.id},
         {"name", name},
         {"template", ""},
         {"shapes", info.shapes},
         {"vertices", info.vertices},
         {"imported", true},
         {"created", info.created},
         {"tenant", info.tenant},
         {"public", info.is_public}});
  return info.id;
}

// A renderer still loading, or held by a stream besides the cache.
bool RendererCache::in_use(const Entry& e) {
  using namespace std::chrono_literals;
  if (e.renderer.wait_for(0s) != std::future_status::ready) return true;
  try {
    return e.renderer.get().use_count() > 1;
  } catch (...) {
    return false;  // failed to load: nothing holds it
  }
}

bool RigRegistry::set_public(const std::string& id, bool is_public) {
  std::lock_guard lock(mutex_);
  sync(id);
  const auto it = infos_.find(id);
  if (it == infos_.end()) return false;
  if (it->second.builtin)
    throw Error("rig '" + id + "' is built in (always public)", ErrorCode::kInvalidInput);
  const fs::path meta_path = rigs_dir_ / id / "meta.json";
  nlohmann::json meta = load_json(meta_path);
  meta["public"] = is_public;
  write_file_atomic(meta_path, meta.dump(2) + "\n");
  it->second.is_public = is_public;
  log::info("rig_public", {{"rig", id}, {"public", is_public}});
  return true;
}

std::shared_ptr<render::Renderer> RendererCache::get(const LoadedRig& rig, int width, int height) {
  const auto key = std::make_tuple(rig.id, width, height);
  std::promise<std::shared_ptr<render::Renderer>> promise;
  std::shared_future<std::shared_ptr<render::Renderer>> future;
  bool loader = false;
  {
    std::lock_guard lock(mutex_);
    auto it = entries_.find(key);
    if (it == entries_.end()) {
      // Make room: drop the least recently used renderer that no stream (playing or queued)
      // holds. Every renderer alive counts, so at most `capacity_` exist at once.
      while (static_cast<int>(entries_.size()) >= capacity_) {
        auto victim = entries_.end();
        for (auto e = entries_.begin(); e != entries_.end(); ++e) {
          if (in_use(e->second)) continue;
          if (victim == entries_.end() || e->second.used < victim->second.used) victim = e;
        }
        if (victim == entries_.end()) {
          throw RequestError(Code::kUnavailable,
                             "frames: " + std::to_string(entries_.size()) +
                                 " renderers (rig x size) are in use by playing or queued "
                                 "streams (max_renderers); use a size in use or retry later");
        }
        entries_.erase(victim);
      }
      future = promise.get_future().share();
      it = entries_.emplace(key, Entry{future, 0}).first;
      loader = true;
    }
    it->second.used = ++clock_;
    future = it->second.renderer;
  }
  if (!loader) return future.get();
  try {
    render::RenderOptions opt = base_;
    opt.width = width;
    opt.height = height;
    opt.contexts = contexts_;
    const auto t0 = std::chrono::steady_clock::now();
    auto r = std::make_shared<render::Renderer>(*rig.rig, opt);
    const std::vector<float> rest(rig.rig->shapes.size(), 0.0f);
    (void)r->render(rest);  // creates the first GL context and uploads the rig
    log::info(
        "renderer_ready",
        {{"rig", rig.id},
         {"size", std::to_string(width) + "x" + std::to_string(height)},
         {"backend", r->backend()},
         {"ms", std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                    .count()}});
    promise.set_value(r);
    return r;
  } catch (...) {
    promise.set_exception(std::current_exception());
    std::lock_guard lock(mutex_);
    entries_.erase(key);
    throw;
  }
}

}  // namespace facecast::server
