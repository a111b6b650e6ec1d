// Live audio in on a WebSocket connection (docs/protocol.md, "Live audio in"): binary messages of
// kind 4 carry PCM16 chunks; the first chunk (first sample 0) opens a weights stream, the chunk
// flagged last (or the next chunk at sample 0) ends it. A bad chunk gets an `error`; the stream
// and the connection stay open.
#include <cstdio>

#include "access.hpp"
#include "live_audio.hpp"
#include "log.hpp"
#include "services.hpp"
#include "websocket_session.hpp"

namespace facecast::server {
namespace {

constexpr double kLiveFps = 60;

const viseme::LipsyncOptions& lipsync_options() {
  static const viseme::LipsyncOptions o = viseme::load_lipsync_options();
  return o;
}

const viseme::AlignOptions& align_options() {
  static const viseme::AlignOptions o = viseme::load_align_options();
  return o;
}

}  // namespace

void WebSocketSession::handle_binary(std::string_view bytes) {
  if (!who_) {
    close_with(websocket::close_code::policy_error, "authenticate first");
    return;
  }
  try {
    services_->access.authorize_live_audio(*who_);
    AudioChunk c = read_audio_chunk(bytes);
    if (c.first == 0 && audio_) end_audio();
    if (!audio_) {
      if (c.first != 0)
        throw Error("audio chunk: first sample " + std::to_string(c.first) +
                    " but no audio stream is open (a stream starts at sample 0)");
      open_audio(c.sample_rate, c.aligned);
    } else if (c.sample_rate != audio_->rate || c.first != audio_->received) {
      throw Error("audio chunk: sample_rate " + std::to_string(c.sample_rate) + ", first " +
                  std::to_string(c.first) + "; the stream expects " + std::to_string(audio_->rate) +
                  " Hz from sample " + std::to_string(audio_->received) + " (chunks follow on)");
    }
    const double audio_end =
        static_cast<double>(audio_->received + c.samples.size()) / c.sample_rate;
    const double elapsed = seconds(Clock::now() - audio_->opened);
    if (audio_end > elapsed + services_->options.live_audio_ahead) {
      char buf[200];
      std::snprintf(buf, sizeof buf,
                    "audio chunk: it ends %.2f s into the stream, %.2f s after it opened; audio "
                    "may run at most live_audio_ahead (%g s) ahead of real time",
                    audio_end, elapsed, services_->options.live_audio_ahead);
      throw RequestError(Code::kRateLimited, buf);
    }
    audio_->received += c.samples.size();
    net::post(audio_->strand, [self = shared_from_this(), engine = audio_->engine,
                               stream = audio_->stream, samples = std::move(c.samples)] {
      if (!engine->lipsync) return;  // making it failed: the error was sent
      std::vector<float> values;
      const int first = engine->lipsync->frames();
      const int n = engine->lipsync->push(samples.data(), samples.size(), values);
      self->post_audio_weights(stream, first, n, engine->lipsync->fps(), std::move(values));
    });
    if (c.last) end_audio();
  } catch (...) {
    send_error(std::nullopt, describe(std::current_exception()));
  }
}

// The stream's engine is made on its strand (loading the rig may take a while); its stream_start
// comes back to the connection before any of its weights.
void WebSocketSession::open_audio(int rate, bool aligned) {
  const std::uint32_t stream = services_->sessions.new_stream_id();
  audio_ = std::make_unique<LiveAudio>(net::make_strand(services_->workers));
  audio_->stream = stream;
  audio_->id = "audio-" + std::to_string(stream);
  audio_->rate = rate;
  net::post(audio_->strand, [self = shared_from_this(), engine = audio_->engine, stream, rate,
                             aligned, id = audio_->id] {
    const viseme::Options& speech = self->services_->speech.viseme_options();
    const viseme::VisemeSet set = speech.set.value_or(viseme::VisemeSet::kOculus);
    try {
      engine->lipsync.emplace(self->services_->rigs.load(""),
                              self->services_->speech.anim_options(), lipsync_options(), speech,
                              rate, kLiveFps, aligned ? &align_options() : nullptr);
    } catch (...) {
      const Problem problem = describe(std::current_exception());
      net::post(self->ws_.get_executor(), [self, id, problem] { self->send_error(id, problem); });
      return;
    }
    StreamStart s;
    s.id = id;
    s.stream = stream;
    s.fps = kLiveFps;
    s.rig = engine->lipsync->rig().id;
    viseme::Utterance empty;
    empty.set = set;
    auto start = OutMessage::control(open_stream_start(stream_start_message(
        s, engine->lipsync->rig().mapping.shape_names(), viseme::to_json(empty))));
    net::post(self->ws_.get_executor(), [self, start = std::move(start), stream, rate] {
      self->send(start);
      log::info("audio_start", {{"conn", self->conn_}, {"stream", stream}, {"rate", rate}});
    });
  });
}

void WebSocketSession::post_audio_weights(std::uint32_t stream, int first, int count, double fps,
                                          std::vector<float> values) {
  if (count <= 0) return;
  auto msg = std::make_shared<const std::string>(
      weights_message(stream, static_cast<std::uint32_t>(first), fps,
                      static_cast<std::uint32_t>(count), values.data(), values.size()));
  net::post(ws_.get_executor(), [self = shared_from_this(), msg = std::move(msg), stream, count] {
    self->send(OutMessage{msg, OutKind::kWeights, stream, static_cast<std::uint32_t>(count)});
  });
}

void WebSocketSession::end_audio() {
  if (!audio_) return;
  net::post(audio_->strand, [self = shared_from_this(), engine = audio_->engine,
                             stream = audio_->stream, id = audio_->id] {
    if (!engine->lipsync) return;
    std::vector<float> values;
    const int first = engine->lipsync->frames();
    const int n = engine->lipsync->finish(values);
    self->post_audio_weights(stream, first, n, engine->lipsync->fps(), std::move(values));
    StreamEnd e;
    e.id = id;
    e.stream = stream;
    e.frames = engine->lipsync->frames();
    net::post(self->ws_.get_executor(), [self, e] {
      self->send(OutMessage::control(stream_end_message(e)));
      log::info("audio_end", {{"conn", self->conn_}, {"stream", *e.stream}, {"frames", e.frames}});
    });
  });
  audio_.reset();
}

template <class Change>
void WebSocketSession::change_live_audio(const char* what, Change change) {
  if (!audio_) throw Error(std::string(what) + ": no live audio stream is open on this connection");
  net::post(audio_->strand,
            [self = shared_from_this(), engine = audio_->engine, change = std::move(change)] {
              if (!engine->lipsync) return;  // making it failed: the error was sent
              try {
                change(*engine->lipsync);
              } catch (...) {
                const Problem problem = describe(std::current_exception());
                net::post(self->ws_.get_executor(),
                          [self, problem] { self->send_error(std::nullopt, problem); });
              }
            });
}

void WebSocketSession::live_text(const AudioTextRequest& text) {
  change_live_audio("audio_text", [text](LiveLipsync& l) { l.add_text(text); });
}

void WebSocketSession::live_expressions(const std::string& tags) {
  change_live_audio("expression", [tags](LiveLipsync& l) { l.add_expressions(tags); });
}

}  // namespace facecast::server
