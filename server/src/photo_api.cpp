// POST /api/photo (an avatar from photos, a job) and POST /api/photo/landmarks (the 68 points of a
// photo, answered at once): rigbuild/photo_avatar.hpp behind HTTP.
#include "api.hpp"

#include <chrono>
#include <map>
#include <mutex>

#include "api.hpp"
#include "facecast/core/error.hpp"
#include "facecast/render/image.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/rigbuild/photo_avatar.hpp"
#include "facecast/rigbuild/template.hpp"
#include "log.hpp"
#include "routes.hpp"
#include "storage.hpp"

#include "facecast/core/json_limits.hpp"

namespace facecast::server {
namespace {

using nlohmann::json;

json parse_object(const Request& req, int max_depth) {
  check_json_depth(req.body(), max_depth, "body");
  json body = json::parse(req.body(), nullptr, false);
  if (body.is_discarded()) throw Error("body: malformed JSON");
  if (!body.is_object()) throw Error("body: expected a JSON object");
  return body;
}

// A photo field: base64 JPEG/PNG bytes, or a data URL ("data:image/jpeg;base64,...") as a
// browser's FileReader or canvas.toDataURL gives it; as 3-channel RGB, upright.
render::Image photo_field(const json& v, const std::string& field,
                          const rig::DecodeLimits& limits) {
  if (!v.is_string()) throw Error(field + ": expected a base64 JPEG or PNG (or a data URL)");
  std::string_view text = v.get_ref<const std::string&>();
  if (text.starts_with("data:")) {
    const auto comma = text.find(',');
    if (comma == std::string_view::npos || text.substr(0, comma).find(";base64") == text.npos)
      throw Error(field + ": a data URL must be base64 (data:image/...;base64,...)");
    text.remove_prefix(comma + 1);
  }
  if (text.empty()) throw Error(field + ": empty");
  // The header's size is checked against the limits before the photo is decoded; a phone's
  // portrait stored sideways is turned upright by its EXIF Orientation.
  return render::decode_photo(base64_decode(text, field), field, limits);
}

// The photo template of configs/rigbuild/photo.json (by default the shipped one), loaded once:
// later jobs share it (read-only).
std::shared_ptr<const rigbuild::PhotoTemplate> photo_template(const std::filesystem::path& path) {
  static std::mutex mutex;
  static std::map<std::filesystem::path, std::shared_ptr<const rigbuild::PhotoTemplate>> cache;
  const std::lock_guard lock(mutex);
  auto& t = cache[path];
  if (!t) t = std::make_shared<const rigbuild::PhotoTemplate>(rigbuild::load_photo_template(path));
  return t;
}

json points_json(const rigbuild::PhotoLandmarks& m) {
  json points = json::array();
  for (const auto& p : m.points) points.push_back({p.x(), p.y()});
  return points;
}

}  // namespace

Jobs::Work RigApi::photo_work(const json& body, const std::string& tenant) {
  if (!body.is_object()) throw Error("body: expected a JSON object");
  std::string name = "Photo avatar";
  RigOwner owner{tenant, false};
  const json* front = nullptr;
  const json* side = nullptr;
  for (const auto& [k, v] : body.items()) {
    if (k == "name") {
      if (!v.is_string()) throw Error("name: expected a string");
      name = v.get<std::string>();
      if (name.empty() || utf8_length(name) > 64) throw Error("name: expected 1 to 64 characters");
    } else if (k == "front") {
      front = &v;
    } else if (k == "side") {
      if (!v.is_null()) side = &v;
    } else if (k == "public") {
      if (!v.is_boolean()) throw Error("public: expected true or false");
      owner.is_public = v.get<bool>();
    } else {
      throw Error("body: unknown field '" + k + "'");
    }
  }
  if (!front) throw Error("front: missing (the front photo, base64 JPEG or PNG)");
  auto photos = std::make_shared<std::vector<render::Image>>();
  photos->push_back(photo_field(*front, "front", s_.options.decode));
  if (side) photos->push_back(photo_field(*side, "side", s_.options.decode));
  const rigbuild::PhotoOptions opt = rigbuild::load_photo_options();
  const std::filesystem::path tmpl_path = rigbuild::photo_template_path(opt, "");
  const std::string template_id = opt.template_path.empty() ? rigbuild::kShippedTemplateId : "";
  log::info("photo_upload", {{"name", name},
                             {"front", std::to_string((*photos)[0].width) + "x" +
                                           std::to_string((*photos)[0].height)},
                             {"side", photos->size() > 1}});
  return [this, photos, opt, tmpl_path, template_id, name, owner](JobContext& ctx) -> json {
    const auto t0 = std::chrono::steady_clock::now();
    ctx.progress("template", 0.0);
    const auto tmpl = photo_template(tmpl_path);
    const rigbuild::PhotoAvatar avatar = rigbuild::avatar_from_photos(
        *tmpl, (*photos)[0], photos->size() > 1 ? &(*photos)[1] : nullptr, opt, ctx.progress_fn());
    ctx.progress("storing", 1.0);
    const std::string glb = rig::glb_bytes(avatar.rig);
    storage_.check_quota(owner.tenant, glb.size());
    const std::string id =
        s_.rigs.add(name, template_id, avatar.rig, glb, avatar.report, {}, {}, owner);
    s_.metrics.rig_build_seconds.observe(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    return {{"rig", id},
            {"url", "/api/rigs/" + id + ".glb"},
            {"notes", avatar.report.value("notes", json::array())},
            {"report", avatar.report}};
  };
}

http::message_generator RigApi::post_photo(const Request& req, const std::string& tenant) {
  const json body = parse_object(req, s_.options.max_json_depth);
  storage_.check_quota(tenant);
  const std::string job = jobs_.submit("photo", photo_work(body, tenant), body, tenant);
  log::info("photo_job", {{"job", job}});
  return reply_.json(req, http::status::accepted, {{"job", job}, {"url", "/api/jobs/" + job}});
}

http::message_generator RigApi::post_photo_landmarks(const Request& req) {
  const json body = parse_object(req, s_.options.max_json_depth);
  const auto job = jobs_.hold("photo landmarks");
  const json* image = nullptr;
  for (const auto& [k, v] : body.items()) {
    if (k == "photo")
      image = &v;
    else
      throw Error("body: unknown field '" + k + "'");
  }
  if (!image) throw Error("photo: missing (base64 JPEG or PNG)");
  const render::Image photo = photo_field(*image, "photo", s_.options.decode);
  const rigbuild::PhotoLandmarks marks =
      rigbuild::detect_photo_landmarks(photo, "photo", rigbuild::load_photo_options());
  return reply_.json(req, http::status::ok,
                     {{"width", photo.width},
                      {"height", photo.height},
                      {"points", points_json(marks)},
                      {"faces", marks.faces},
                      {"box", marks.box},
                      {"roll", marks.roll},
                      {"note", marks.note}});
}

}  // namespace facecast::server
