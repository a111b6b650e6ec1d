// Live audio-only lip-sync: see live_audio.hpp and docs/algorithms.md#audio-lipsync.
#include "live_audio.hpp"

#include <bit>
#include <cstring>
#include <string>

#include "facecast/core/error.hpp"
#include "facecast/rig/motion.hpp"

namespace facecast::server {
namespace {

std::uint32_t u32_at(std::string_view b, std::size_t at) {
  std::uint32_t v = 0;
  for (int k = 3; k >= 0; --k)
    v = (v << 8) | static_cast<unsigned char>(b[at + static_cast<std::size_t>(k)]);
  return v;
}

}  // namespace

AudioChunk read_audio_chunk(std::string_view b) {
  if (b.size() < 24)
    throw Error("audio chunk: " + std::to_string(b.size()) + " bytes, shorter than the header");
  if (static_cast<std::uint8_t>(b[0]) != kAudioInKind)
    throw Error("binary message: kind " + std::to_string(static_cast<unsigned char>(b[0])) +
                "; clients send only audio chunks (kind 4)");
  if (b[1] != 1) throw Error("audio chunk: version " + std::to_string(b[1]) + ", expected 1");
  AudioChunk c;
  const unsigned flags = static_cast<unsigned char>(b[2]) | static_cast<unsigned char>(b[3]) << 8;
  if (flags & ~unsigned{kAudioInLast | kAudioInAligned})
    throw Error("audio chunk: unknown flags " + std::to_string(flags));
  c.last = flags & kAudioInLast;
  c.aligned = flags & kAudioInAligned;
  const std::uint32_t rate = u32_at(b, 4);
  if (rate < 8000 || rate > 48000)
    throw Error("audio chunk: sample_rate " + std::to_string(rate) + " outside 8000..48000");
  c.sample_rate = static_cast<int>(rate);
  c.first = u32_at(b, 8);
  if (c.aligned && c.first != 0)
    throw Error("audio chunk: flag 2 (aligned) is for the first chunk of a stream (sample 0)");
  const std::uint32_t count = u32_at(b, 12);
  if (b.size() != 24 + 2 * static_cast<std::size_t>(count))
    throw Error("audio chunk: count " + std::to_string(count) + " samples but " +
                std::to_string(b.size() - 24) + " payload bytes (2 per sample)");
  c.samples.resize(count);
  for (std::uint32_t i = 0; i < count; ++i)
    c.samples[i] = static_cast<std::int16_t>(static_cast<unsigned char>(b[24 + 2 * i]) |
                                             static_cast<unsigned char>(b[25 + 2 * i]) << 8);
  return c;
}

LiveLipsync::LiveLipsync(std::shared_ptr<const LoadedRig> rig, const anim::AnimOptions& anim,
                         const viseme::LipsyncOptions& options, const viseme::Options& speech,
                         int input_rate, double fps, const viseme::AlignOptions* align)
    : rig_(std::move(rig)),
      anim_(anim),
      options_(options),
      set_(speech.set.value_or(viseme::VisemeSet::kOculus)),
      fps_(fps),
      resampler_(input_rate, 16000),
      analyzer_(16000, options) {
  anim_.idle = false;  // idle life is a function of the whole utterance; the client adds its own
  if (align) {
    viseme::Options o = speech;  // the server's voice and lexicon read the stream's text
    o.set = set_;
    aligner_.emplace(input_rate, o, *align);
  }
}

void LiveLipsync::add_text(const AudioTextRequest& text) {
  if (!aligner_)
    throw Error("audio_text: the open audio stream is not aligned (flag 2 on its first chunk)");
  if (text.start)
    aligner_->add_timed_text(text.text, *text.start, *text.end);
  else
    aligner_->add_text(text.text);
  if (text.final) aligner_->end_text();
}

int LiveLipsync::push(const std::int16_t* pcm, std::size_t n, std::vector<float>& values) {
  std::vector<float> in(n);
  for (std::size_t i = 0; i < n; ++i) in[i] = static_cast<float>(pcm[i]) / 32768.0f;
  samples_ += n;
  if (aligner_) {
    aligner_->add_audio(in.data(), n);
    return emit(-1, values);
  }
  resampled_.clear();
  resampler_.push(in.data(), n, resampled_);
  frames_.clear();
  analyzer_.push(resampled_.data(), resampled_.size(), frames_);
  return emit(-1, values);
}

int LiveLipsync::finish(std::vector<float>& values) {
  frames_.clear();
  if (aligner_)
    aligner_->finish();
  else
    analyzer_.finish(frames_);
  return emit(static_cast<double>(samples_) / input_rate(), values);
}

void LiveLipsync::add_expressions(std::string_view tags) {
  for (auto& e : viseme::parse_expression_tags(tags, next_frame_ / fps_))
    expressions_.push_back(std::move(e));
}

// Frames up to the analysed audio minus `delay` (or up to `until` at the end) from one
// Performance over the recent events. The open last event is taken to go on for `delay` more,
// so its key is not pulled towards rest before the audio says so. Aligned: frames up to what the
// aligner has decided; its events after that are its best guess so far, so no delay is needed.
int LiveLipsync::emit(double until, std::vector<float>& values) {
  if (aligner_) {
    events_ = aligner_->visemes();
    for (auto& e : aligner_->take_expressions()) expressions_.push_back(std::move(e));
    analysed_ = aligner_->decided();
    return sample(until >= 0 ? until : analysed_, false, values);
  }
  constexpr double kHop = 0.01;
  viseme::append_lipsync_events(frames_, set_, options_, kHop, events_);
  if (!frames_.empty()) analysed_ = frames_.back().time + kHop / 2;
  return sample(until >= 0 ? until : analysed_ - options_.delay, until < 0, values);
}

int LiveLipsync::sample(double end, bool open_last, std::vector<float>& values) {
  if (next_frame_ / fps_ > end) return 0;
  const double keep = next_frame_ / fps_ - options_.window;
  std::erase_if(events_, [&](const viseme::VisemeEvent& e) { return e.end < keep; });
  viseme::Utterance u;
  u.set = set_;
  u.visemes = events_;
  u.expressions = expressions_;
  if (open_last && !u.visemes.empty()) u.visemes.back().end += options_.delay;
  u.duration = std::max(analysed_, u.visemes.empty() ? 0.0 : u.visemes.back().end);
  const anim::Performance p(u, rig_->mapping, anim_);
  const std::size_t shapes = rig_->mapping.shape_names().size();
  int count = 0;
  for (; next_frame_ / fps_ <= end; ++next_frame_, ++count) {
    const std::size_t at = values.size();
    values.resize(at + shapes + rig::BodyPose::kChannels.size());
    rig::BodyPose pose;
    p.sample(next_frame_ / fps_, std::span<float>(values.data() + at, shapes), &pose);
    std::ranges::copy(pose.channels(), values.begin() + static_cast<std::ptrdiff_t>(at + shapes));
  }
  return count;
}

}  // namespace facecast::server
