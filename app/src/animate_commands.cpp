// facecast animate --text T | --timestamps FILE | --fap FILE [--rig rig.glb] [--fps 60]
//   --out weights.json|.bin|take.csv|anim.fap, or --vmc HOST:PORT
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <thread>

#include <unistd.h>

#include "facecast/anim/live_link.hpp"
#include "facecast/app/commands.hpp"
#include "facecast/app/timeline_plot.hpp"
#include "facecast/avatar/avatar.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/core/subprocess.hpp"
#include "facecast/core/wav.hpp"
#include "facecast/rig/rig_io.hpp"
#include "facecast/server/vmc.hpp"
#include "facecast/viseme/viseme.hpp"
#include "speech_input.hpp"

namespace facecast::cli {

namespace fs = std::filesystem;

void add_speech_options(CLI::App* cmd, SpeechArgs& a) {
  cmd->add_option("--text", a.text, "Text to speak (Chinese/English, expression tags allowed)");
  cmd->add_option("--timestamps", a.timestamps,
                  "Phoneme/viseme timestamps (Azure, Polly, MFA, Rhubarb, ElevenLabs or JSON)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--timestamps-format", a.timestamps_format,
                  "auto (from the content), json, azure, polly, mfa, rhubarb or elevenlabs")
      ->capture_default_str();
  cmd->add_option("--lang", a.lang, "Language runs: auto, zh or en")
      ->check(CLI::IsMember({"auto", "zh", "en"}))
      ->capture_default_str();
  cmd->add_option("--timing", a.timing, "model or tts (default: tts when there is audio)")
      ->check(CLI::IsMember({"model", "tts"}));
  cmd->add_option("--rate", a.rate, "Duration-model speech rate, syllables per second")
      ->check(CLI::Range(0.5, 20.0));
  cmd->add_option("--voice", a.voice, "espeak-ng voice for English (default en-us)");
  cmd->add_option("--idle", a.idle, "Blinks, small eye and head motion, breathing: on or off")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  cmd->add_option("--fap", a.fap,
                  "An MPEG-4 FAP file (FBA ASCII) to play instead of speech: FAPs 1-68 drive the "
                  "rig through its feature points (anim/fap.hpp)")
      ->check(CLI::ExistingFile);
}

viseme::Utterance speech_utterance(const SpeechArgs& a, bool tts, const std::string& audio) {
  if (a.text.empty() == a.timestamps.empty())
    throw Error("give exactly one of --text or --timestamps");
  viseme::Options o = viseme::load_options();
  o.lang = viseme::parse_lang_mode(a.lang);
  if (a.rate > 0) o.rate = a.rate;
  if (!a.voice.empty()) o.en_voice = a.voice;
  if (!a.timestamps.empty()) {
    const std::string content = read_file(a.timestamps);
    const auto format = a.timestamps_format == "auto"
                            ? viseme::detect_timestamp_format(content, a.timestamps)
                            : viseme::parse_timestamp_format(a.timestamps_format);
    return viseme::import_timestamps(format, content, o, viseme::PhoneSet::kAuto, a.timestamps);
  }
  if (!audio.empty())
    return viseme::align(a.text, viseme::read_audio(audio, viseme::load_audio_options()), o,
                         viseme::load_align_options());
  o.timing = !a.timing.empty() ? viseme::parse_timing(a.timing)
             : tts             ? viseme::Timing::kTts
                               : viseme::Timing::kModel;
  return viseme::analyze(a.text, o);
}

Speech speech_with_audio(const SpeechArgs& a, const std::string& audio) {
  const bool file = !audio.empty() && audio != "tts" && audio != "none";
  Speech s;
  if (file && a.text.empty()) {
    // The recording is the sound, decoded once: lip-synced alone, or beside --timestamps.
    const auto in = viseme::read_audio(audio, viseme::load_audio_options());
    s.utterance = a.given()
                      ? speech_utterance(a, false)
                      : viseme::lipsync(in, viseme::load_options(), viseme::load_lipsync_options());
    s.pcm = viseme::to_pcm16(in.samples);
    s.sample_rate = in.sample_rate;
    return s;
  }
  // --text aligned to the recording (its speech comes back in the utterance), espeak-ng, or none.
  s.utterance = speech_utterance(a, audio == "tts", file ? audio : "");
  if (audio != "none" && !audio.empty()) {
    s.pcm = s.utterance.pcm;
    s.sample_rate = s.utterance.sample_rate;
  }
  return s;
}

anim::AnimOptions speech_anim_options(const SpeechArgs& a) {
  anim::AnimOptions o = anim::load_anim_options();
  o.idle = a.idle == "on";
  return o;
}

namespace {

struct AnimateArgs {
  SpeechArgs speech;
  std::string rig, out, plot, vmc, vmc_names = "perfect-sync", audio, wav;
  double fps = 60;
  bool play = false;
};

// Plays `wav` on this machine's sound output through ffplay (SDL picks the device).
std::unique_ptr<Child> play_sound(const std::string& wav) {
  return std::make_unique<Child>(
      std::vector<std::string>{"ffplay", "-nodisp", "-autoexit", "-loglevel", "error", wav},
      std::vector<ChildFd>{
          {0, ChildFd::Kind::kNull}, {1, ChildFd::Kind::kNull}, {2, ChildFd::Kind::kRead}});
}

// Plays `p` to a VMC receiver in real time: frame f leaves at start + f / fps. With `sound`, the
// speech starts playing locally at the first frame.
void play_vmc(const anim::Performance& p, const server::VmcTarget& target, server::VmcNames names,
              double fps, const std::string& sound) {
  server::VmcSender sender(target, names);
  const auto& shapes = p.shape_names();
  std::vector<float> w(shapes.size());
  rig::BodyPose head;
  const int frames = p.frame_count(fps);
  const auto player = sound.empty() ? nullptr : play_sound(sound);
  const auto start = std::chrono::steady_clock::now();
  for (int f = 0; f < frames; ++f) {
    const double t = f / fps;
    std::this_thread::sleep_until(start +
                                  std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                      std::chrono::duration<double>(t)));
    p.sample(t, w, &head);
    sender.send(shapes, w, head, t);
  }
  std::cerr << "sent " << frames << " frames to " << target.host << ":" << target.port << " ("
            << p.duration() << " s)\n";
  if (player) {
    const ExitStatus st = player->finish(p.duration() + 5);
    if (!st.ok())
      std::cerr << "facecast: warning: ffplay could not play the sound: "
                << player->output(2).substr(0, 200) << "\n";
  }
}

// The speech's sound: the --audio file, espeak-ng's when it is wanted (--wav, --play, --timing
// tts), else none.
std::string audio_mode(const AnimateArgs& a) {
  if (!a.audio.empty()) return a.audio;
  return a.speech.timing == "tts" || (!a.speech.text.empty() && (!a.wav.empty() || a.play))
             ? "tts"
             : "none";
}

// The speech as a WAV for --wav, or for --play alone a temporary one; "" when neither is asked.
std::string write_sound(const AnimateArgs& a, const Speech& s) {
  if (a.wav.empty() && !a.play) return "";
  if (s.pcm.empty())
    throw Error(std::string(a.play ? "--play" : "--wav") +
                ": there is no speech audio (give --text, or --audio FILE)");
  std::string path = a.wav;
  if (path.empty())
    path = (fs::temp_directory_path() / ("facecast-play-" + std::to_string(::getpid()) + ".wav"))
               .string();
  write_file_atomic(path, encode_wav(s.pcm, s.sample_rate));
  return path;
}

}  // namespace

void add_animate_commands(CLI::App& app) {
  auto a = std::make_shared<AnimateArgs>();
  auto* cmd = app.add_subcommand(
      "animate",
      "Text or timestamps -> blendshape weights per frame (JSON, binary or a Live Link Face take)");
  add_speech_options(cmd, a->speech);
  cmd->add_option("--rig", a->rig, "Rig (GLB or OBJ folder); default: the built-in avatar")
      ->check(CLI::ExistingPath);
  cmd->add_option("--fps", a->fps, "Frames per second")
      ->check(CLI::Range(1.0, 240.0))
      ->capture_default_str();
  cmd->add_option("--vmc", a->vmc,
                  "Play to a VMC receiver (VSeeFace, Warudo, VNyan...) in real time: HOST:PORT "
                  "(its port is usually 39539)");
  cmd->add_option("--vmc-names", a->vmc_names,
                  "The receiver's shape names: perfect-sync (the 52 ARKit names), vrm0 "
                  "(A I U E O, Blink, Joy...) or vrm1 (aa ih ou ee oh, blink, happy...)")
      ->check(CLI::IsMember({"perfect-sync", "vrm0", "vrm1"}))
      ->capture_default_str();
  cmd->add_option("--audio", a->audio,
                  "Speech audio: --text is aligned to it; alone, audio-only lip-sync (any format "
                  "ffmpeg/libsndfile reads)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--wav", a->wav,
                  "Also write the speech (espeak-ng's for --text, or the --audio file's) as a WAV "
                  "that starts at frame 0, to play beside the weights");
  cmd->add_flag("--play", a->play,
                "With --vmc: play the speech on this machine's sound output (ffplay) as the "
                "bundles go");
  cmd->add_option("--out", a->out,
                  "weights.json ({fps, frames, shapes, weights, head}), weights.bin (FCWT: see "
                  "anim/animation.hpp) or take.csv (a Live Link Face take: the 52 ARKit shapes "
                  "and the head, for Unreal and Blender; anim/live_link.hpp); needed unless "
                  "--vmc is given");
  cmd->add_option("--plot", a->plot,
                  "Also draw the timeline (viseme events and curves, expressions, jaw, blink) "
                  "as a PNG");
  cmd->callback([a] {
    if (a->out.empty() && a->vmc.empty()) throw Error("give --out FILE or --vmc HOST:PORT");
    const bool binary = a->out.ends_with(".bin"), take = a->out.ends_with(".csv"),
               fap = a->out.ends_with(".fap");
    if (!a->out.empty() && !binary && !take && !fap && !a->out.ends_with(".json"))
      throw Error("--out: '" + a->out + "' must end in .json, .bin, .csv or .fap");
    if (!a->vmc.empty()) {
      if (!a->out.empty() || !a->rig.empty() || !a->speech.fap.empty())
        throw Error(
            "--vmc: plays speech to the receiver's own avatar; leave --out, --rig and "
            "--fap out");
      const auto target = server::parse_vmc_target(a->vmc, "--vmc");
      const auto names = server::parse_vmc_names(a->vmc_names, "--vmc-names");
      const Speech s = speech_with_audio(a->speech, audio_mode(*a));
      const std::string sound = write_sound(*a, s);
      const anim::Mapping mapping = anim::Mapping::for_rig(server::vmc_shape_names(names));
      play_vmc(anim::Performance(s.utterance, mapping, speech_anim_options(a->speech)), target,
               names, a->fps, a->play ? sound : "");
      if (a->wav.empty() && !sound.empty()) fs::remove(sound);
      return;
    }
    if (a->play) throw Error("--play plays beside --vmc; give --wav to keep the sound");
    if (take && !a->rig.empty() && a->speech.fap.empty())
      throw Error(
          "--rig: a Live Link Face take (.csv) holds the 52 ARKit shapes of any face; "
          "leave --rig out");
    if (!a->speech.fap.empty() && a->speech.given())
      throw Error("--fap plays a FAP file; leave --text and --timestamps out");
    // FAPs (in or out) live on a rig's geometry; a take drives an ARKit face whatever the rig;
    // otherwise the rig's own shapes.
    std::optional<rig::Rig> rig;
    if (fap || !a->speech.fap.empty())
      rig = a->rig.empty() ? avatar::default_avatar() : rig::load_rig(a->rig);
    const std::vector<std::string> shapes = rig    ? rig->shape_names()
                                            : take ? anim::arkit_shape_names()
                                            : a->rig.empty()
                                                ? avatar::avatar_shape_names()  // not generated
                                                : rig::load_rig(a->rig).shape_names();
    std::optional<anim::FapRig> fap_measured;
    if (rig) fap_measured.emplace(fap_rig(*rig));
    std::unique_ptr<rig::Motion> motion;
    std::optional<viseme::Utterance> u;
    std::string source = "an MPEG-4 FAP file";
    if (!a->speech.fap.empty()) {
      motion = std::make_unique<anim::FapMotion>(read_fap_motion(a->speech.fap, *fap_measured));
    } else {
      const Speech s = speech_with_audio(a->speech, audio_mode(*a));
      (void)write_sound(*a, s);
      u = s.utterance;
      const anim::Mapping mapping = anim::Mapping::for_rig(shapes);
      source = mapping.table() + " mapping";
      motion = std::make_unique<anim::Performance>(*u, mapping, speech_anim_options(a->speech));
    }
    const auto* performance = dynamic_cast<const anim::Performance*>(motion.get());
    std::string bytes;
    if (fap) {
      const std::string name = fs::path(a->out).stem().string();
      bytes =
          anim::to_fap_text(performance ? anim::to_fap(*performance, *fap_measured, a->fps, name)
                                        : anim::to_fap(*motion, *fap_measured, a->fps, name));
    } else {
      const anim::WeightTrack track = anim::bake(*motion, a->fps);
      bytes = take     ? anim::to_live_link_csv(track)
              : binary ? anim::to_binary(track)
                       : anim::to_json(track) + "\n";
    }
    write_file_atomic(a->out, bytes);
    if (!a->plot.empty()) {
      if (!performance) throw Error("--plot draws speech; a FAP file has no visemes to draw");
      render::write_image(a->plot, plot_timeline(*u, *performance));
    }
    const int frames = static_cast<int>(std::ceil(motion->duration() * a->fps - 1e-9));
    std::cerr << "wrote " << a->out << ": " << frames << " frames x " << shapes.size()
              << " shapes at " << a->fps << " fps (" << motion->duration() << " s, " << source
              << ")\n";
  });
}

}  // namespace facecast::cli
