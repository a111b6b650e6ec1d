// Offline video: speech -> MP4 through ffmpeg (duration, audio, a moving mouth that rests in
// pauses) and frame sequences.
#include <catch2/catch.hpp>
#include <cstdio>
#include <filesystem>

#include "facecast/anim/animation.hpp"
#include "facecast/avatar/avatar.hpp"
#include "facecast/core/error.hpp"
#include "facecast/render/video.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/viseme/analyze.hpp"
#include "test_data.hpp"

using namespace facecast;
namespace fs = std::filesystem;

namespace {

std::string run(const std::string& command) {
  std::string out;
  FILE* p = popen(command.c_str(), "r");
  REQUIRE(p != nullptr);
  char buf[65536];
  for (size_t n; (n = fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
  pclose(p);
  return out;
}

// Decodes a video into raw RGB frames of w x h.
std::vector<std::string> decode(const fs::path& video, int w, int h) {
  const std::string raw =
      run("ffmpeg -v error -i '" + video.string() + "' -f rawvideo -pix_fmt rgb24 pipe:1");
  const size_t frame = static_cast<size_t>(w) * h * 3;
  std::vector<std::string> frames;
  for (size_t at = 0; at + frame <= raw.size(); at += frame)
    frames.push_back(raw.substr(at, frame));
  return frames;
}

// Mean absolute difference over the pixels of `mask`.
double diff(const std::string& a, const std::string& b, const std::vector<size_t>& mask) {
  double sum = 0;
  for (const size_t i : mask)
    sum += std::abs(static_cast<int>(static_cast<unsigned char>(a[i])) -
                    static_cast<int>(static_cast<unsigned char>(b[i])));
  return sum / std::max<size_t>(1, mask.size());
}

}  // namespace

TEST_CASE("speech to MP4 with the ICT FaceKit", "[render][video]") {
  const auto dir = test::ict_dir();
  if (!test::require_data(dir / "generic_neutral_mesh.obj")) return;
  const rig::Rig rig = rig::read_obj_shapes(dir / "generic_neutral_mesh.obj", dir, {"identity*"});
  viseme::Options vo;
  vo.timing = viseme::Timing::kTts;
  const auto u = viseme::analyze(
      "(joy, 30, 0.5)大家好，欢迎来到发布会。我们今天发布新的产品…… Hello everyone, welcome!", vo);
  REQUIRE(!u.pcm.empty());
  const double audio_seconds = static_cast<double>(u.pcm.size()) / u.sample_rate;
  CHECK(audio_seconds > 4.0);

  anim::AnimOptions ao;
  ao.idle = false;  // no head motion: pixels change only where the face speaks
  const anim::Mapping mapping = anim::Mapping::for_rig(rig.shape_names());
  const anim::Performance performance(u, mapping, ao);
  render::RenderOptions ro;
  ro.width = 320;
  ro.height = 240;
  const render::Renderer renderer(rig, ro);
  render::VideoOptions video;
  video.fps = 25;
  const fs::path out = test::scratch_dir() / "ict_speech.mp4";
  fs::remove(out);
  const auto result = render::write_video(renderer, performance, u.pcm, u.sample_rate, out, video);
  REQUIRE(fs::exists(out));
  for (const auto& e : fs::directory_iterator(out.parent_path()))
    CHECK(e.path().filename().string().rfind(".tmp-", 0) != 0);  // nothing half-written left

  // Container: H.264 yuv420p + AAC, durations within one frame of the audio.
  const std::string probe =
      run("ffprobe -v error -show_entries stream=codec_name,pix_fmt,duration "
          "-of csv=p=0 '" +
          out.string() + "'");
  CHECK_THAT(probe, Catch::Contains("h264,yuv420p"));
  CHECK_THAT(probe, Catch::Contains("aac"));
  const double video_seconds = std::stod(probe.substr(probe.find("yuv420p,") + 8));
  CHECK(std::abs(video_seconds - audio_seconds) <= 1.0 / video.fps + 1e-6);
  CHECK(result.frames == static_cast<int>(std::ceil(audio_seconds * video.fps - 1e-9)));

  // The mouth region: where jawOpen changes the picture.
  const auto neutral = renderer.render(std::vector<float>(rig.shapes.size(), 0.0f));
  std::vector<float> open(rig.shapes.size(), 0.0f);
  open[rig.find_shape("jawOpen")] = 1.0f;
  const auto jaw = renderer.render(open);
  std::vector<size_t> mouth;
  for (size_t i = 0; i < neutral.pixels.size(); ++i)
    if (std::abs(neutral.pixels[i] - jaw.pixels[i]) > 40) mouth.push_back(i);
  REQUIRE(mouth.size() > 100);

  const auto frames = decode(out, ro.width, ro.height);
  REQUIRE(static_cast<int>(frames.size()) == result.frames);
  const auto motion = [&](double t) {
    const int f = static_cast<int>(t * video.fps);
    return diff(frames[f], frames[f + 1], mouth);
  };
  // Speaking: the mouth moves between frames in most sounding visemes.
  int moving = 0, sounding = 0;
  for (const auto& v : u.visemes) {
    if (v.viseme == "sil" || v.end - v.start < 0.08) continue;
    ++sounding;
    moving += motion(v.start) > 1.0 || motion(0.5 * (v.start + v.end)) > 1.0;
  }
  CHECK(moving > 0.6 * sounding);
  // Long pauses (the ellipsis, the end): still once the rest ramp is over.
  int pauses = 0;
  for (const auto& v : u.visemes) {
    if (v.viseme != "sil" || v.end - v.start < 0.45) continue;
    for (double t = v.start + ao.rest_ramp + 0.08; t + 2.0 / video.fps < v.end - ao.rest_ramp;
         t += 1.0 / video.fps) {
      INFO("pause at " << t);
      CHECK(motion(t) < 0.6);
    }
    ++pauses;
  }
  CHECK(pauses >= 1);
  // Saved for people to look at: a contact sheet of every 8th frame, and the video.
  const int every = 8, cols = 6;
  const int n = (static_cast<int>(frames.size()) + every - 1) / every;
  render::Image sheet{ro.width * cols, ro.height * ((n + cols - 1) / cols), 3, {}};
  sheet.pixels.assign(static_cast<size_t>(sheet.width) * sheet.height * 3, 0);
  for (int k = 0; k < n; ++k)
    for (int y = 0; y < ro.height; ++y)
      std::copy_n(
          frames[static_cast<size_t>(k * every)].begin() + static_cast<long>(y) * ro.width * 3,
          ro.width * 3,
          sheet.pixels.begin() + ((static_cast<long>(k / cols) * ro.height + y) * sheet.width +
                                  (k % cols) * ro.width) *
                                     3);
  const auto art = test::artifacts_dir("video");
  render::write_image(art / "ict_speech_sheet.png", sheet);
  fs::copy_file(out, art / "ict_speech.mp4", fs::copy_options::overwrite_existing);
}

TEST_CASE("a frame sequence with its WAV, and ffmpeg errors", "[render][video]") {
  const rig::Rig rig = avatar::default_avatar();
  viseme::Utterance u;
  u.set = viseme::VisemeSet::kOculus;
  u.visemes = {{"sil", 0, 0.1}, {"aa", 0.1, 0.3}, {"sil", 0.3, 0.4}};
  u.duration = 0.4;
  u.pcm.assign(8820, 0);  // 0.4 s at 22050 Hz
  u.sample_rate = 22050;
  const anim::Performance p(u, anim::Mapping::for_rig(rig.shape_names()));
  render::RenderOptions ro;
  ro.width = 64;
  ro.height = 48;
  const render::Renderer renderer(rig, ro);
  const fs::path dir = test::scratch_dir() / "frames";
  fs::remove_all(dir);
  render::VideoOptions vo;
  vo.fps = 20;
  const auto r = render::write_video(renderer, p, u.pcm, u.sample_rate, dir / "%04d.png", vo);
  CHECK(r.frames == 8);
  CHECK(fs::exists(dir / "0000.png"));
  CHECK(fs::exists(dir / "0007.png"));
  CHECK(!fs::exists(dir / "0008.png"));
  CHECK(fs::exists(dir / "audio.wav"));

  CHECK_THROWS_WITH(render::write_video(renderer, p, u.pcm, u.sample_rate, dir / "x.gif", vo),
                    Catch::Contains("x.gif"));
  vo.preset = "no-such-preset";  // ffmpeg refuses: its own message comes back, no file is left
  const fs::path bad = test::scratch_dir() / "bad.mp4";
  CHECK_THROWS_WITH(render::write_video(renderer, p, u.pcm, u.sample_rate, bad, vo),
                    Catch::Contains("ffmpeg failed"));
  CHECK(!fs::exists(bad));

  // The encoder: x264 unless the renderer is on an NVIDIA GPU where NVENC works; NVENC asked for
  // where it does not work is ffmpeg's error, and no file.
  vo.preset = "veryfast";
  const fs::path mp4 = test::scratch_dir() / "encoder.mp4";
  const bool gpu = renderer.backend().find("NVIDIA") != std::string::npos;
  const auto x264 = render::write_video(renderer, p, u.pcm, u.sample_rate, mp4, vo);
  CHECK((gpu || x264.encoder == "libx264"));
  CHECK(fs::exists(mp4));
  vo.encoder = render::VideoOptions::Encoder::kNvenc;
  fs::remove(mp4);
  try {
    const auto nvenc = render::write_video(renderer, p, u.pcm, u.sample_rate, mp4, vo);
    CHECK(nvenc.encoder == "h264_nvenc");
  } catch (const facecast::Error& e) {
    INFO(e.what());
    CHECK_THAT(e.what(), Catch::Contains("ffmpeg failed"));
    CHECK(!fs::exists(mp4));
  }
}

TEST_CASE("configs/render/render.json mirrors RenderOptions and VideoOptions", "[render][video]") {
  const render::RenderOptions file = render::load_render_options(), code;
  CHECK(file.width == code.width);
  CHECK(file.height == code.height);
  CHECK(file.msaa == code.msaa);
  CHECK(file.trilinear == code.trilinear);
  CHECK(file.fast_srgb == code.fast_srgb);
  CHECK(file.fov_y_deg == code.fov_y_deg);
  CHECK(file.margin == code.margin);
  CHECK(file.background == code.background);
  CHECK(file.framing == code.framing);
  CHECK(file.background_image == code.background_image);
  CHECK(file.contexts == code.contexts);
  CHECK(file.lod_pixels == code.lod_pixels);
  const render::VideoOptions vfile = render::load_video_options(), vcode;
  CHECK(vfile.fps == vcode.fps);
  CHECK(vfile.crf == vcode.crf);
  CHECK(vfile.preset == vcode.preset);
  CHECK(vfile.audio_bitrate_kbps == vcode.audio_bitrate_kbps);
  CHECK(vfile.pipeline == vcode.pipeline);
  CHECK(vfile.ffmpeg == vcode.ffmpeg);
  CHECK(vfile.encoder == vcode.encoder);
}
