// RenderOptions and VideoOptions from configs/anim/render.json.
#include <nlohmann/json.hpp>

#include "facecast/core/config.hpp"
#include "facecast/core/error.hpp"
#include "facecast/render/renderer.hpp"
#include "facecast/render/video.hpp"

namespace facecast::render {
namespace {

template <class T>
void get(const nlohmann::json& j, const char* key, T& value, const std::string& where) {
  if (!j.contains(key)) throw Error(where + ": missing field '" + key + "'");
  try {
    j.at(key).get_to(value);
  } catch (const nlohmann::json::exception&) {
    throw Error(where + ": field '" + key + "' has the wrong type");
  }
}

}  // namespace

RenderOptions load_render_options() {
  const auto path = config_path("anim/render.json");
  const auto j = load_json(path);
  const std::string where = path.string();
  RenderOptions o;
  get(j, "width", o.width, where);
  get(j, "height", o.height, where);
  get(j, "msaa", o.msaa, where);
  get(j, "fov_y_deg", o.fov_y_deg, where);
  get(j, "margin", o.margin, where);
  std::vector<float> bg;
  get(j, "background_srgb", bg, where);
  if (bg.size() != 3) throw Error(where + ": field 'background_srgb' needs 3 numbers");
  o.background = {bg[0], bg[1], bg[2]};
  get(j, "contexts", o.contexts, where);
  return o;
}

VideoOptions load_video_options() {
  const auto path = config_path("anim/render.json");
  const auto j = load_json(path);
  const std::string where = path.string() + ": video";
  if (!j.contains("video")) throw Error(path.string() + ": missing field 'video'");
  const auto& v = j.at("video");
  VideoOptions o;
  get(v, "fps", o.fps, where);
  get(v, "crf", o.crf, where);
  get(v, "preset", o.preset, where);
  get(v, "audio_bitrate_kbps", o.audio_bitrate_kbps, where);
  get(v, "pipeline", o.pipeline, where);
  get(v, "ffmpeg", o.ffmpeg, where);
  return o;
}

}  // namespace facecast::render
