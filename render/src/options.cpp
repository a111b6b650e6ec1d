// RenderOptions and VideoOptions from configs/render/render.json (the video options under "video").
#include <array>

#include "facecast/core/config.hpp"
#include "facecast/core/config_reader.hpp"
#include "facecast/render/renderer.hpp"
#include "facecast/render/video.hpp"

namespace facecast::render {
namespace {

struct Options {
  RenderOptions render;
  VideoOptions video;
};

// One reader for the whole file, so that a key of either part is known to the other's check.
Options load_options() {
  ConfigReader c = ConfigReader::open(config_path("render/render.json"));
  Options o;
  RenderOptions& r = o.render;
  std::array<float, 3> background{r.background.x(), r.background.y(), r.background.z()};
  c.read("width", r.width)
      .read("height", r.height)
      .read("msaa", r.msaa)
      .read("trilinear", r.trilinear)
      .read("fast_srgb", r.fast_srgb)
      .read("fov_y_deg", r.fov_y_deg)
      .read("margin", r.margin)
      .read_choice("framing", r.framing,
                   {{"face", Framing::kFace}, {"bust", Framing::kBust}, {"full", Framing::kFull}})
      .read("background_srgb", background)
      .read("background_image", r.background_image)
      .read("contexts", r.contexts)
      .read("lod_pixels", r.lod_pixels);
  r.background = {background[0], background[1], background[2]};
  VideoOptions& v = o.video;
  c.section("video")
      .read("fps", v.fps)
      .read("crf", v.crf)
      .read("preset", v.preset)
      .read("audio_bitrate_kbps", v.audio_bitrate_kbps)
      .read("pipeline", v.pipeline)
      .read("ffmpeg", v.ffmpeg)
      .read_choice("encoder", v.encoder,
                   {{"auto", VideoOptions::Encoder::kAuto},
                    {"x264", VideoOptions::Encoder::kX264},
                    {"nvenc", VideoOptions::Encoder::kNvenc}});
  c.reject_unknown();
  return o;
}

}  // namespace

RenderOptions load_render_options() {
  return load_options().render;
}

VideoOptions load_video_options() {
  return load_options().video;
}

}  // namespace facecast::render
