// facecast visemes | tts
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

#include "facecast/app/commands.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/viseme/viseme.hpp"

namespace facecast::cli {
namespace {

struct CommonArgs {
  std::string lang = "auto", set = "auto", timing, voice;
  double rate = 0;
};

struct VisemesArgs {
  CommonArgs common;
  std::string text, input, format = "json", phoneset = "auto", audio, tags;
  std::vector<std::string> from;
};

struct TtsArgs {
  CommonArgs common;
  std::string text, out, timing_out;
};

void add_common(CLI::App* cmd, CommonArgs& a, bool timing) {
  cmd->add_option("--lang", a.lang, "Language runs: auto (by script), zh or en")
      ->check(CLI::IsMember({"auto", "zh", "en"}))
      ->capture_default_str();
  cmd->add_option("--set", a.set, "Viseme set: zh15, mpeg4, oculus, or auto (zh15 if any Chinese)")
      ->check(CLI::IsMember({"auto", "zh15", "mpeg4", "oculus"}))
      ->capture_default_str();
  if (timing)
    cmd->add_option("--timing", a.timing,
                    "model (duration model, no audio) or tts (espeak-ng synthesis); default from "
                    "configs/viseme/options.json")
        ->check(CLI::IsMember({"model", "tts"}));
  cmd->add_option("--rate", a.rate, "Duration-model speech rate, syllables per second")
      ->check(CLI::Range(0.5, 20.0));
  cmd->add_option("--voice", a.voice, "espeak-ng voice for English (default en-us)");
}

viseme::Options options_from(const CommonArgs& a) {
  viseme::Options o = viseme::load_options();
  o.lang = viseme::parse_lang_mode(a.lang);
  o.set = viseme::parse_set_option(a.set);
  if (!a.timing.empty()) o.timing = viseme::parse_timing(a.timing);
  if (a.rate > 0) o.rate = a.rate;
  if (!a.voice.empty()) o.en_voice = a.voice;
  return o;
}

void print_tsv(std::ostream& out, const viseme::Utterance& u, const std::string& prefix) {
  out << std::fixed << std::setprecision(4);
  for (const auto& v : u.visemes)
    out << prefix << v.start << '\t' << v.end << '\t' << v.viseme << '\n';
  out.unsetf(std::ios::floatfield);
}

void print(const viseme::Utterance& u, const std::string& format, bool lines) {
  if (format == "tsv") {
    print_tsv(std::cout, u, "");
  } else {
    std::cout << (lines ? viseme::to_json(u).dump() : viseme::to_json(u).dump(2)) << '\n';
  }
}

// --input: one utterance per line in, one JSON object (or TSV block) per line out. A line that
// fails gives {"error": ...} and the command exits non-zero at the end.
void run_lines(std::istream& in, const VisemesArgs& a, const viseme::Options& o) {
  std::size_t n = 0, failed = 0;
  std::string first_error;
  for (std::string line; std::getline(in, line);) {
    ++n;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    try {
      const viseme::Utterance u = viseme::analyze(line, o);
      if (a.format == "tsv")
        print_tsv(std::cout, u, std::to_string(n) + '\t');
      else
        std::cout << viseme::to_json(u).dump() << '\n';
    } catch (const Error& e) {
      if (!failed++) first_error = "line " + std::to_string(n) + ": " + e.what();
      if (a.format == "json")
        std::cout << nlohmann::json{{"text", line}, {"error", e.what()}}.dump() << '\n';
    }
  }
  std::cout.flush();
  if (failed)
    throw Error(a.input + ": " + std::to_string(failed) + " of " + std::to_string(n) +
                " lines failed; first: " + first_error);
}

void run_visemes(const VisemesArgs& a) {
  const viseme::Options o = options_from(a.common);
  const int sources = !a.text.empty() + !a.input.empty() + !a.from.empty();
  if (!a.audio.empty()) {
    if (!a.input.empty() || !a.from.empty()) throw Error("--audio combines with --text only");
    const viseme::Audio audio = viseme::read_audio(a.audio, viseme::load_audio_options());
    if (a.text.empty()) {
      try {  // audio-only lip-sync (docs/algorithms.md#audio-lipsync)
        return print(viseme::lipsync(audio, o, viseme::load_lipsync_options(), a.tags), a.format,
                     false);
      } catch (const Error& e) {
        throw Error(a.audio + ": " + e.what());
      }
    }
    return print(viseme::align(a.text, audio, o, viseme::load_align_options()), a.format, false);
  }
  if (sources != 1) throw Error("give exactly one of --text, --input or --from");
  if (!a.from.empty()) {
    const auto format = viseme::parse_timestamp_format(a.from[0]);
    const std::string content = read_file(a.from[1]);
    print(viseme::import_timestamps(format, content, o, viseme::parse_phone_set(a.phoneset),
                                    a.from[1]),
          a.format, false);
  } else if (!a.input.empty()) {
    if (a.input == "-") {
      run_lines(std::cin, a, o);
    } else {
      std::istringstream in(read_file(a.input));
      run_lines(in, a, o);
    }
  } else {
    print(viseme::analyze(a.text, o), a.format, false);
  }
}

void run_tts(const TtsArgs& a) {
  viseme::Options o = options_from(a.common);
  o.timing = viseme::Timing::kTts;
  const viseme::Utterance u = viseme::analyze(a.text, o);
  write_file_atomic(a.out, facecast::encode_wav(u.pcm, u.sample_rate));
  if (!a.timing_out.empty()) write_file_atomic(a.timing_out, viseme::to_json(u).dump(2) + "\n");
  std::cerr << "wrote " << a.out << ": " << u.duration << " s, " << u.visemes.size()
            << " visemes\n";
}

}  // namespace

void add_viseme_commands(CLI::App& app) {
  auto va = std::make_shared<VisemesArgs>();
  auto* v = app.add_subcommand("visemes",
                               "Text with (expression, intensity, seconds) tags, or TTS/aligner "
                               "timestamps, to timed visemes");
  v->add_option("--text", va->text, "Text to analyze (with --audio: the words spoken in it)");
  v->add_option("--audio", va->audio,
                "Speech audio (any format ffmpeg/libsndfile reads): times the --text on it; "
                "without --text, audio-only lip-sync");
  v->add_option("--tags", va->tags,
                "With --audio and no --text: expression tags at times, \"(smile,40,0.5)@1.2 ...\"");
  v->add_option("--input", va->input,
                "File (or - for stdin) with one utterance per line: JSON Lines out");
  v->add_option("--from", va->from,
                "Convert timestamps: azure|polly|mfa|rhubarb|elevenlabs|json FILE")
      ->expected(2);
  v->add_option("--phoneset", va->phoneset,
                "Phones of --from json/mfa: auto, pinyin, arpabet, ipa, espeak")
      ->check(CLI::IsMember({"auto", "pinyin", "arpabet", "ipa", "espeak"}))
      ->capture_default_str();
  v->add_option("--format", va->format, "Output: json, or tsv (start, end, viseme)")
      ->check(CLI::IsMember({"json", "tsv"}))
      ->capture_default_str();
  add_common(v, va->common, true);
  v->callback([va] { run_visemes(*va); });

  auto ta = std::make_shared<TtsArgs>();
  auto* t =
      app.add_subcommand("tts", "Speak text with espeak-ng: a WAV file and the same timing JSON");
  t->add_option("--text", ta->text, "Text to speak (expression tags allowed)")->required();
  t->add_option("--out", ta->out, "Output WAV (PCM16 mono)")->required();
  t->add_option("--timing-out", ta->timing_out, "Also write the utterance JSON here");
  add_common(t, ta->common, false);
  t->callback([ta] { run_tts(*ta); });
}

}  // namespace facecast::cli
