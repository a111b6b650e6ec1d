// Live audio in on a WebSocket connection (docs/protocol.md, "Live audio in"): binary messages of
// kind 4 carry PCM16 chunks; the first chunk (first sample 0) opens a weights stream, the chunk
// flagged last (or the next chunk at sample 0) ends it. A bad chunk gets an `error`; the stream
// and the connection stay open.
#include <cstdio>

#include "access.hpp"
#include "live_audio.hpp"
#include "log.hpp"
#include "websocket_session.hpp"

namespace facecast::server {
namespace {

constexpr double kLiveFps = 60;

const viseme::LipsyncOptions& lipsync_options() {
  static const viseme::LipsyncOptions o = viseme::load_lipsync_options();
  return o;
}

}  // namespace

void WebSocketSession::handle_binary(std::string_view bytes) {
  if (!who_) {
    close_with(websocket::close_code::policy_error, "authenticate first");
    return;
  }
  try {
    authorize_live_audio(*state_, *who_);
    AudioChunk c = read_audio_chunk(bytes);
    if (c.first == 0 && audio_) end_audio();
    if (!audio_) {
      if (c.first != 0)
        throw Error("audio chunk: first sample " + std::to_string(c.first) +
                    " but no audio stream is open (a stream starts at sample 0)");
      const std::uint32_t stream = state_->next_stream.fetch_add(1);
      audio_ = std::make_unique<LiveAudio>(
          LiveAudio{LiveLipsync(state_->rigs.load(""), state_->anim_options, lipsync_options(),
                                state_->viseme_options.set.value_or(viseme::VisemeSet::kOculus),
                                c.sample_rate, kLiveFps),
                    stream, "audio-" + std::to_string(stream)});
      StreamStart s;
      s.id = audio_->id;
      s.stream = stream;
      s.fps = kLiveFps;
      s.rig = audio_->engine.rig().id;
      viseme::Utterance empty;
      empty.set = state_->viseme_options.set.value_or(viseme::VisemeSet::kOculus);
      send(OutMessage::control(open_stream_start(stream_start_message(
          s, audio_->engine.rig().mapping.shape_names(), viseme::to_json(empty)))));
      log::info("audio_start", {{"conn", conn_}, {"stream", stream}, {"rate", c.sample_rate}});
    } else if (c.sample_rate != audio_->engine.input_rate() ||
               c.first != audio_->engine.samples()) {
      throw Error("audio chunk: sample_rate " + std::to_string(c.sample_rate) + ", first " +
                  std::to_string(c.first) + "; the stream expects " +
                  std::to_string(audio_->engine.input_rate()) + " Hz from sample " +
                  std::to_string(audio_->engine.samples()) + " (chunks follow on)");
    }
    const double audio_end =
        static_cast<double>(audio_->engine.samples() + c.samples.size()) / c.sample_rate;
    const double elapsed = seconds(Clock::now() - audio_->opened);
    if (audio_end > elapsed + state_->options.live_audio_ahead) {
      char buf[200];
      std::snprintf(buf, sizeof buf,
                    "audio chunk: it ends %.2f s into the stream, %.2f s after it opened; audio "
                    "may run at most live_audio_ahead (%g s) ahead of real time",
                    audio_end, elapsed, state_->options.live_audio_ahead);
      throw RequestError(Code::kRateLimited, buf);
    }
    std::vector<float> values;
    const int first = audio_->engine.frames();
    const int n = audio_->engine.push(c.samples.data(), c.samples.size(), values);
    send_audio_weights(first, n, values);
    if (c.last) end_audio();
  } catch (...) {
    send_error(std::nullopt, describe(std::current_exception()));
  }
}

void WebSocketSession::send_audio_weights(int first, int count, const std::vector<float>& values) {
  if (count <= 0) return;
  auto msg = std::make_shared<const std::string>(
      weights_message(audio_->stream, static_cast<std::uint32_t>(first), audio_->engine.fps(),
                      static_cast<std::uint32_t>(count), values.data(), values.size()));
  send(OutMessage{std::move(msg), OutKind::kWeights, audio_->stream,
                  static_cast<std::uint32_t>(count)});
}

void WebSocketSession::end_audio() {
  if (!audio_) return;
  std::vector<float> values;
  const int first = audio_->engine.frames();
  send_audio_weights(first, audio_->engine.finish(values), values);
  StreamEnd e;
  e.id = audio_->id;
  e.stream = audio_->stream;
  e.frames = audio_->engine.frames();
  send(OutMessage::control(stream_end_message(e)));
  log::info("audio_end", {{"conn", conn_}, {"stream", audio_->stream}, {"frames", e.frames}});
  audio_.reset();
}

}  // namespace facecast::server
