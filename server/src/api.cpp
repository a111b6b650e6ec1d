#include "api.hpp"

#include "access.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/render/image.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/rigbuild/build.hpp"
#include "facecast/rigbuild/build_target.hpp"
#include "facecast/rigbuild/correspondence.hpp"
#include "facecast/rigbuild/landmarks.hpp"
#include "facecast/rigbuild/picture.hpp"
#include "log.hpp"
#include "routes.hpp"
#include "storage.hpp"
#include "video.hpp"

#include "facecast/core/json_limits.hpp"

namespace facecast::server {
namespace {

using nlohmann::json;

json parse_body(const Request& req, int max_depth) {
  check_json_depth(req.body(), max_depth, "body");
  try {
    return json::parse(req.body());
  } catch (const json::exception& e) {  // parse_error, out_of_range (number overflow)
    std::string what = e.what();
    if (const auto p = what.find("] "); p != std::string::npos) what = what.substr(p + 2);
    throw Error("body: malformed JSON: " + what);
  }
}

const std::string& str(const json& v, const std::string& field) {
  if (!v.is_string()) throw Error(field + ": expected a string");
  return v.get_ref<const std::string&>();
}

double number(const json& v, const std::string& field, double lo, double hi) {
  if (!v.is_number()) throw Error(field + ": expected a number");
  const double x = v.get<double>();
  if (!(x >= lo && x <= hi)) {
    char buf[128];
    std::snprintf(buf, sizeof buf, "%s: %g is outside [%g, %g]", field.c_str(), x, lo, hi);
    throw Error(buf);
  }
  return x;
}

}  // namespace

std::string base64_decode(std::string_view text, std::string_view field) {
  static const auto table = [] {
    std::array<int, 256> t{};
    t.fill(-1);
    const char* alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (int i = 0; i < 64; ++i) t[static_cast<unsigned char>(alphabet[i])] = i;
    return t;
  }();
  std::string out;
  out.reserve(text.size() / 4 * 3);
  std::uint32_t acc = 0;
  int bits = 0;
  bool padding = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == ' ' || c == '\n' || c == '\r' || c == '\t') continue;
    if (c == '=') {
      padding = true;
      continue;
    }
    const int v = table[static_cast<unsigned char>(c)];
    if (v < 0 || padding)
      throw Error(std::string(field) + ": not base64 (character " + std::to_string(i) + ")");
    acc = (acc << 6) | static_cast<std::uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((acc >> bits) & 0xFF);
    }
  }
  if (bits >= 6) throw Error(std::string(field) + ": truncated base64");
  return out;
}

namespace {

// The "mesh" field of a rig or landmarks request: an OBJ's text, or a base64 GLB/VRM, read as a
// build target (an avatar is kept: the built shapes go into its own meshes).
std::shared_ptr<rigbuild::BuildTarget> parse_mesh(const json* mesh,
                                                  const rig::DecodeLimits& limits) {
  if (!mesh) throw Error("mesh: missing ({\"format\": \"obj\"|\"glb\", \"data\": ...})");
  if (!mesh->is_object() || !mesh->contains("format") || !mesh->contains("data"))
    throw Error("mesh: expected {\"format\": \"obj\"|\"glb\", \"data\": ...}");
  const std::string& format = str(mesh->at("format"), "mesh.format");
  const std::string& data = str(mesh->at("data"), "mesh.data");
  if (format != "obj" && format != "glb" && format != "vrm")
    throw Error("mesh.format: '" + format + "' is not obj, glb or vrm");
  auto user = std::make_shared<rigbuild::BuildTarget>(rigbuild::BuildTarget::parse(
      format == "obj" ? data : base64_decode(data, "mesh.data"), format, "mesh", limits));
  user->neutral().validate("mesh");
  return user;
}

std::string base64_encode(std::string_view bytes) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  const auto at = [&](std::size_t i) {
    return i < bytes.size() ? static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[i])) : 0u;
  };
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    const std::uint32_t v = at(i) << 16 | at(i + 1) << 8 | at(i + 2);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(v >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kAlphabet[v & 63] : '=';
  }
  return out;
}

}  // namespace

http::message_generator RigApi::post_landmarks(const Request& req, const Principal& who) {
  const json body = parse_body(req, s_.options.max_json_depth);
  if (!body.is_object()) throw Error("body: expected a JSON object");
  std::string template_id = s_.options.default_rig;
  const json* mesh = nullptr;
  for (const auto& [k, v] : body.items()) {
    if (k == "template")
      template_id = str(v, "template");
    else if (k == "mesh")
      mesh = &v;
    else
      throw Error("body: unknown field '" + k + "'");
  }
  std::shared_ptr<const rigbuild::BuildTarget> user = parse_mesh(mesh, s_.options.decode);
  (void)access_.usable_rig(who, template_id);
  const auto tmpl = s_.rigs.load(template_id);
  const std::string job = jobs_.submit(
      "landmarks",
      [tmpl, user](JobContext& ctx) -> json {
        ctx.progress("landmarks", 0.0);
        const rigbuild::AutoMarkers found =
            rigbuild::auto_markers(*tmpl->rig, user->neutral(), rigbuild::load_landmark_options());
        json pairs = json::array(), vertices = json::array();
        for (const auto& m : found.markers)
          pairs.push_back(
              {{"name", m.name}, {"template", m.template_vertex}, {"target", m.target_vertex}});
        for (const int v : found.target.vertex) vertices.push_back(v < 0 ? json(nullptr) : json(v));
        const std::string jpeg = render::encode_jpeg(rigbuild::landmark_picture(found.target), 85);
        return {{"template", tmpl->id},
                {"markers", {{"index_base", 0}, {"pairs", pairs}}},
                {"target_vertices", vertices},
                {"views_found", found.target.views_found},
                {"dropped", found.target.dropped},
                {"seconds", found.seconds},
                {"picture", "data:image/jpeg;base64," + base64_encode(jpeg)}};
      },
      {}, who.tenant);
  log::info("landmarks_upload", {{"job", job}, {"template", tmpl->id}});
  return reply_.json(req, http::status::accepted, {{"job", job}, {"url", "/api/jobs/" + job}});
}

// ?public=1 / true / yes.
bool public_query(const Target& t) {
  const auto v = query_value(t.query, "public");
  return v && (*v == "1" || *v == "true" || *v == "yes");
}

// POST /api/rigs with a GLB or VRM body: the user's avatar, stored as it is (?name= names it).
http::message_generator RigApi::import_rig(const Request& req, const Target& t,
                                           const Principal& who) {
  std::string name = query_value(t.query, "name").value_or("Avatar");
  if (name.empty() || utf8_length(name) > 64) throw Error("name: expected 1 to 64 characters");
  const std::string& bytes = req.body();
  if (bytes.empty()) throw Error("body: empty (expected a GLB or VRM file)");
  const auto job = jobs_.hold("rig import");
  storage_.check_quota(who.tenant, bytes.size());
  const std::string id =
      s_.rigs.import(name, bytes, "upload", RigOwner{who.tenant, public_query(t)});
  const auto info = s_.rigs.find(id);
  log::info("rig_import", {{"rig", id}, {"name", name}, {"bytes", bytes.size()}});
  return reply_.json(req, http::status::created, info->to_json());
}

// A rig build from a POST /api/rigs JSON body: checked here (throws Error naming the field), run
// by a job worker (with Redis, on any instance: the body is the job's payload).
Jobs::Work RigApi::rig_work(const json& body, const std::string& tenant) {
  if (!body.is_object()) throw Error("body: expected a JSON object");
  std::string name = "Rig", template_id = s_.options.default_rig;
  RigOwner owner{tenant, false};
  const json* mesh = nullptr;
  const json* markers = nullptr;
  rigbuild::BuildOptions opt = rigbuild::load_build_options();  // configs/rigbuild/build.json
  for (const auto& [k, v] : body.items()) {
    if (k == "name") {
      name = str(v, "name");
      if (name.empty() || utf8_length(name) > 64) throw Error("name: expected 1 to 64 characters");
    } else if (k == "template") {
      template_id = str(v, "template");
    } else if (k == "mesh") {
      mesh = &v;
    } else if (k == "markers") {
      if (!v.is_null()) markers = &v;
    } else if (k == "public") {
      if (!v.is_boolean()) throw Error("public: expected true or false");
      owner.is_public = v.get<bool>();
    } else if (k == "options") {
      if (!v.is_object()) throw Error("options: expected an object");
      for (const auto& [ok, ov] : v.items()) {
        if (ok == "virtual_edges") {
          const std::string& mode = str(ov, "options.virtual_edges");
          if (mode != "auto" && mode != "off")
            throw Error("options.virtual_edges: '" + mode + "' is not auto or off");
          opt.virtual_edges =
              mode == "auto" ? rigbuild::VirtualEdgeMode::kAuto : rigbuild::VirtualEdgeMode::kOff;
        } else if (ok == "lambda") {
          opt.lambda = number(ov, "options.lambda", 0, 1e6);
        } else if (ok == "contacts") {
          if (!ov.is_boolean()) throw Error("options.contacts: expected true or false");
          opt.contacts.enabled = ov.get<bool>();
        } else {
          throw Error("options: unknown field '" + ok + "'");
        }
      }
    } else {
      throw Error("body: unknown field '" + k + "'");
    }
  }
  auto user = parse_mesh(mesh, s_.options.decode);
  rig::Rig& target = user->neutral();
  const auto tmpl = s_.rigs.load(template_id);

  // Without markers, another topology is registered through landmarks found automatically on
  // rendered views of the mesh (in the job: a mesh that is not a head fails there, saying so).
  if (markers)
    opt.markers = rigbuild::parse_markers(*markers, tmpl->rig->vertex_count(),
                                          target.vertex_count(), "markers");
  else
    rigbuild::reorder_triangles_like(*tmpl->rig, target);
  const int vertices = target.vertex_count();
  log::info("rig_upload", {{"name", name},
                           {"template", tmpl->id},
                           {"vertices", vertices},
                           {"markers", markers != nullptr}});
  std::shared_ptr<const rigbuild::BuildTarget> shared_target = std::move(user);
  return [this, shared_target, tmpl, opt, name, owner](JobContext& ctx) -> json {
    const auto t0 = std::chrono::steady_clock::now();
    const auto r =
        rigbuild::build_rig(*tmpl->rig, shared_target->neutral(), opt, ctx.progress_fn());
    const json report = rigbuild::build_report_json(r, opt);
    ctx.progress("storing", 1.0);
    const std::string glb = shared_target->glb_bytes(r.rig);
    storage_.check_quota(owner.tenant, glb.size());
    const std::string id = s_.rigs.add(name, tmpl->id, r.rig, glb, report,
                                       opt.virtual_edges != rigbuild::VirtualEdgeMode::kOff
                                           ? r.virtual_edges
                                           : std::vector<rigbuild::VirtualEdge>{},
                                       r.ve_stats, owner);
    s_.metrics.rig_build_seconds.observe(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    return {{"rig", id}, {"url", "/api/rigs/" + id + ".glb"}, {"report", report}};
  };
}

http::message_generator RigApi::post_rig(const Request& req, const Target& t,
                                         const Principal& who) {
  const std::string type(req[http::field::content_type]);
  if (type.starts_with("model/gltf-binary") || type.starts_with("model/vrm") ||
      type.starts_with("application/octet-stream"))
    return import_rig(req, t, who);
  json body = parse_body(req, s_.options.max_json_depth);
  storage_.check_quota(who.tenant);
  if (body.is_object()) {
    if (const auto it = body.find("template"); it != body.end() && it->is_string())
      (void)access_.usable_rig(who, it->get<std::string>());
    if (public_query(t)) body["public"] = true;  // the payload carries it (Redis)
  }
  const std::string job = jobs_.submit("rig", rig_work(body, who.tenant), body, who.tenant);
  log::info("rig_job", {{"job", job}});
  return reply_.json(req, http::status::accepted, {{"job", job}, {"url", "/api/jobs/" + job}});
}

// A video render from a POST /api/render body (checked here, run by a job worker).
Jobs::Work RigApi::render_work(const json& body) {
  if (!body.is_object()) throw Error("body: expected a JSON object");
  VideoRequest r;
  r.rig = s_.options.default_rig;
  bool have_text = false;
  for (const auto& [k, v] : body.items()) {
    if (k == "text") {
      r.text = str(v, "text");
      const std::size_t n = utf8_length(r.text);
      if (n == 0) throw Error("text: empty");
      if (n > s_.options.max_text)
        throw RequestError(Code::kLimit, "text: " + std::to_string(n) +
                                             " characters, the limit is " +
                                             std::to_string(s_.options.max_text));
      have_text = true;
    } else if (k == "rig") {
      r.rig = str(v, "rig");
    } else if (k == "fps") {
      r.fps = number(v, "fps", 1, 60);
    } else if (k == "size") {
      if (!v.is_array() || v.size() != 2 || !v[0].is_number_integer() || !v[1].is_number_integer())
        throw Error("size: expected [width, height] in pixels");
      const double hi = s_.options.max_frame_side;
      r.width = static_cast<int>(number(v[0], "size[0]", 16, hi));
      r.height = static_cast<int>(number(v[1], "size[1]", 16, hi));
      if (r.width % 2 || r.height % 2) throw Error("size: width and height must be even (H.264)");
    } else if (k == "audio") {
      if (!v.is_boolean()) throw Error("audio: expected true or false");
      r.audio = v.get<bool>();
    } else if (k == "lang") {
      r.lang = viseme::parse_lang_mode(str(v, "lang"));
    } else if (k == "voice") {
      r.voice = str(v, "voice");
    } else if (k == "rate") {
      r.rate = number(v, "rate", 0.5, 20);
    } else if (k == "idle") {
      if (!v.is_boolean()) throw Error("idle: expected true or false");
      r.idle = v.get<bool>();
    } else {
      throw Error("body: unknown field '" + k + "'");
    }
  }
  if (!have_text) throw Error("text: missing");
  if (!s_.rigs.find(r.rig)) throw Error("rig '" + r.rig + "' does not exist", ErrorCode::kNotFound);
  log::info("render_request", {{"rig", r.rig},
                               {"fps", r.fps},
                               {"size", std::to_string(r.width) + "x" + std::to_string(r.height)}});
  return [&streams = s_, r](JobContext& ctx) { return render_video(streams, r, ctx); };
}

http::message_generator RigApi::post_render(const Request& req, const Principal& who) {
  const json body = parse_body(req, s_.options.max_json_depth);
  if (body.is_object()) {
    const auto it = body.find("rig");
    (void)access_.usable_rig(who,
                             it != body.end() && it->is_string() ? it->get<std::string>() : "");
  }
  storage_.check_quota(who.tenant);
  const std::string job = jobs_.submit("render", render_work(body), body, who.tenant);
  log::info("render_job", {{"job", job}});
  return reply_.json(req, http::status::accepted, {{"job", job}, {"url", "/api/jobs/" + job}});
}

http::message_generator RigApi::patch_rig(const Request& req, const std::string& id) {
  const json body = parse_body(req, s_.options.max_json_depth);
  if (!body.is_object() || body.size() != 1 || !body.contains("public") ||
      !body["public"].is_boolean())
    throw Error("body: expected {\"public\": true|false}");
  if (!s_.rigs.set_public(id, body["public"].get<bool>()))
    throw Error("rig '" + id + "' does not exist", ErrorCode::kNotFound);
  return reply_.json(req, http::status::ok, s_.rigs.find(id)->to_json());
}

Jobs::Work RigApi::job_work(const std::string& kind, const json& payload,
                            const std::string& tenant) {
  if (kind == "rig") return rig_work(payload, tenant);
  if (kind == "render") return render_work(payload);
  if (kind == "photo") return photo_work(payload, tenant);
  throw Error("job kind '" + kind + "' is not rig, render or photo");
}

}  // namespace facecast::server
