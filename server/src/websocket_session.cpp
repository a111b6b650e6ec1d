#include "websocket_session.hpp"

#include <cmath>

#include "facecast/render/image.hpp"
#include "log.hpp"

namespace facecast::server {
namespace {

using nlohmann::json;

std::string dump(const json& j) {
  return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

double seconds(std::chrono::steady_clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

std::chrono::steady_clock::duration from_seconds(double s) {
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(s));
}

// Frames whose send time is within this of "now" go out in this wake-up.
constexpr double kSlack = 0.0005;

}  // namespace

struct WebSocketSession::Item {
  SpeakRequest request;
  Clock::time_point received;
  std::optional<Clock::time_point> front_at;  // reached the front with nothing playing
  std::uint32_t seed = 1;
  bool cancelled = false;
  std::shared_ptr<PreparedSpeech> prepared;
};

struct WebSocketSession::Stream {
  std::shared_ptr<Item> item;
  std::shared_ptr<PreparedSpeech> p;
  std::uint32_t id = 0;
  Clock::time_point start;
  double fps = 60;
  bool frames_mode = false;
  int end_frame = 0;   // frames [0, end_frame) are sent (grows/shrinks on cancel)
  int next_frame = 0;  // next frame to sample or render
  int sent = 0, dropped = 0;
  bool first_sent = false;
  std::size_t audio_next = 0, audio_chunk = 0;
  int names = 0, values = 0;  // shapes, shapes + head pose
  std::vector<float> last;    // values of the last frame sampled
  bool have_last = false;
  bool cancelling = false;
  int fade_start = 0;
  std::vector<float> fade_from;
  struct Render {
    int frame = 0;
    bool done = false;
    std::shared_ptr<const std::string> message;  // null if it failed
  };
  std::deque<Render> in_flight;  // launch order = frame order
  std::optional<Problem> render_error;
};

WebSocketSession::WebSocketSession(tcp::socket&& socket, std::shared_ptr<State> state,
                                   std::unique_ptr<ConnectionSlot> slot, std::uint64_t id,
                                   std::string remote)
    : ws_(std::move(socket)),
      state_(std::move(state)),
      slot_(std::move(slot)),
      id_(id),
      conn_("c" + std::to_string(id)),
      remote_(std::move(remote)),
      timer_(ws_.get_executor()),
      watchdog_(ws_.get_executor()),
      close_timer_(ws_.get_executor()),
      tokens_(state_->options.speak_burst) {
  state_->metrics.ws_connections.fetch_add(1);
}

WebSocketSession::~WebSocketSession() {
  state_->metrics.ws_connections.fetch_sub(1);
  state_->metrics.write_queue_depth.fetch_sub(static_cast<long>(queue_.size()));
  state_->metrics.speak_queue_depth.fetch_sub(static_cast<long>(pending_.size()));
  if (active_) state_->metrics.active_streams.fetch_sub(1);
  state_->remove_session(id_);
}

void WebSocketSession::run(Request request, bool subprotocol) {
  const auto& o = state_->options;
  beast::get_lowest_layer(ws_).expires_never();  // the websocket has its own timeouts
  websocket::stream_base::timeout t{};
  t.handshake_timeout = from_seconds(o.ws_handshake_timeout);
  t.idle_timeout = from_seconds(o.ws_idle_timeout);
  t.keep_alive_pings = true;
  ws_.set_option(t);
  ws_.set_option(websocket::stream_base::decorator([subprotocol](websocket::response_type& res) {
    res.set(http::field::server, "facecast");
    if (subprotocol) res.set(http::field::sec_websocket_protocol, kSubprotocol);
  }));
  ws_.read_message_max(o.max_message);
  ws_.auto_fragment(false);
  state_->add_session(id_, weak_from_this());
  ws_.async_accept(request,
                   beast::bind_front_handler(&WebSocketSession::on_accept, shared_from_this()));
}

void WebSocketSession::shut_down() {
  net::post(ws_.get_executor(), [self = shared_from_this()] {
    if (!self->accepted_) {
      beast::error_code ec;
      beast::get_lowest_layer(self->ws_).socket().close(ec);
      return;
    }
    self->close_with(websocket::close_code::going_away, "server shutting down");
  });
}

void WebSocketSession::on_accept(beast::error_code ec) {
  if (ec) {
    log::info("ws_handshake_failed", {{"conn", conn_}, {"error", ec.message()}});
    return;
  }
  accepted_ = true;
  if (state_->stopping) {
    close_with(websocket::close_code::going_away, "server shutting down");
    return;
  }
  log::info("ws_open", {{"conn", conn_}, {"remote", remote_}});
  json rigs = json::array();
  for (const auto& r : state_->rigs.list()) rigs.push_back(r.id);
  const auto& o = state_->options;
  send_control(dump({{"type", "hello"},
                     {"protocol", kSubprotocol},
                     {"server", "facecast " FACECAST_VERSION},
                     {"rigs", rigs},
                     {"default_rig", o.default_rig},
                     {"limits",
                      {{"max_text", o.max_text},
                       {"max_message", o.max_message},
                       {"speak_per_minute", o.speak_per_minute},
                       {"speak_burst", o.speak_burst},
                       {"max_queued_speaks", o.max_queued_speaks},
                       {"max_fps", o.max_fps},
                       {"max_frame_side", o.max_frame_side}}},
                     {"lead", o.lead}}));
  do_read();
}

void WebSocketSession::do_read() {
  ws_.async_read(buffer_,
                 beast::bind_front_handler(&WebSocketSession::on_read, shared_from_this()));
}

void WebSocketSession::on_read(beast::error_code ec, std::size_t) {
  if (ec) {
    if (ec == websocket::error::message_too_big) {
      log::warn("ws_message_too_big", {{"conn", conn_}, {"limit", state_->options.max_message}});
    }
    on_closed();
    return;
  }
  state_->metrics.ws_messages_received_total.fetch_add(1);
  if (closing_) {
    buffer_.consume(buffer_.size());
    do_read();
    return;
  }
  if (ws_.got_text()) {
    const auto data = buffer_.data();
    handle_text(std::string_view(static_cast<const char*>(data.data()), data.size()));
  } else {
    send_error(std::nullopt, Problem{Code::kInvalidInput,
                                     "binary messages are not accepted; send JSON text", 400});
  }
  buffer_.consume(buffer_.size());
  do_read();
}

void WebSocketSession::send_error(const std::optional<std::string>& id, const Problem& problem) {
  state_->metrics.protocol_errors_total.fetch_add(1);
  log::info("ws_error", {{"conn", conn_},
                         {"id", id ? *id : std::string("null")},
                         {"code", to_string(problem.code)},
                         {"message", problem.message}});
  send_control(error_message(id, problem));
}

void WebSocketSession::handle_text(std::string_view text) {
  std::string id;
  try {
    ClientMessage m = parse_client_message(text, state_->limits, &id);
    if (auto* speak = std::get_if<SpeakRequest>(&m)) {
      on_speak(std::move(*speak));
    } else if (auto* cancel = std::get_if<CancelRequest>(&m)) {
      on_cancel(*cancel);
    } else if (auto* ping = std::get_if<PingRequest>(&m)) {
      send_control(dump({{"type", "pong"}, {"t", ping->t}, {"server_time", state_->uptime()}}));
    }
  } catch (...) {
    send_error(id.empty() ? std::nullopt : std::optional<std::string>(id),
               describe(std::current_exception()));
  }
}

void WebSocketSession::on_speak(SpeakRequest&& request) {
  const auto& o = state_->options;
  const auto now = Clock::now();
  tokens_ = std::min<double>(o.speak_burst,
                             tokens_ + seconds(now - tokens_at_) * o.speak_per_minute / 60.0);
  tokens_at_ = now;
  if (tokens_ < 1.0) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "speak: more than %g per minute (burst %d); wait and retry",
                  o.speak_per_minute, o.speak_burst);
    throw RequestError(Code::kRateLimited, buf);
  }
  const int queued = static_cast<int>(pending_.size()) + (active_ ? 1 : 0);
  if (queued >= o.max_queued_speaks) {
    throw RequestError(Code::kLimit, "speak: " + std::to_string(queued) +
                                         " utterances are playing or queued (max_queued_speaks)");
  }
  const auto same_id = [&](const std::shared_ptr<Item>& i) { return i->request.id == request.id; };
  if ((active_ && same_id(active_->item)) || std::any_of(pending_.begin(), pending_.end(), same_id))
    throw Error("id: '" + request.id + "' is already playing or queued");
  const std::string rig = state_->rigs.resolve(request.rig);
  if (!state_->rigs.find(rig))
    throw Error("rig '" + rig + "' does not exist", ErrorCode::kNotFound);
  tokens_ -= 1.0;

  auto item = std::make_shared<Item>();
  item->request = std::move(request);
  item->received = now;
  item->seed = state_->next_stream.load() ^ static_cast<std::uint32_t>(id_ * 2654435761u);
  pending_.push_back(item);
  state_->metrics.speak_queue_depth.fetch_add(1);
  log::info("speak", {{"conn", conn_},
                      {"id", item->request.id},
                      {"rig", rig},
                      {"output", item->request.output == Output::kFrames ? "frames" : "weights"},
                      {"fps", item->request.fps},
                      {"audio", item->request.audio},
                      {"queued", pending_.size() - 1 + (active_ ? 1 : 0)}});
  prepare(item);
  start_next();
}

void WebSocketSession::on_cancel(const CancelRequest& request) {
  if (active_ && active_->item->request.id == request.id) {
    if (!active_->cancelling) begin_cancel();
    return;
  }
  const auto it = std::find_if(pending_.begin(), pending_.end(),
                               [&](const auto& i) { return i->request.id == request.id; });
  if (it == pending_.end())
    throw Error("cancel: no utterance '" + request.id + "' is playing or queued",
                ErrorCode::kNotFound);
  (*it)->cancelled = true;
  pending_.erase(it);
  state_->metrics.speak_queue_depth.fetch_sub(1);
  log::info("cancelled_queued", {{"conn", conn_}, {"id", request.id}});
  send_control(dump({{"type", "stream_end"},
                     {"id", request.id},
                     {"stream", nullptr},
                     {"frames", 0},
                     {"dropped", 0},
                     {"cancelled", true}}));
}

// ---- preparation (worker pool) ----------------------------------------------------------------

void WebSocketSession::prepare(const std::shared_ptr<Item>& item) {
  net::post(state_->workers, [self = shared_from_this(), item] {
    std::shared_ptr<PreparedSpeech> prepared;
    std::optional<Problem> problem;
    try {
      prepared = prepare_speech(*self->state_, item->request, item->seed);
    } catch (...) {
      problem = describe(std::current_exception());
    }
    net::post(self->ws_.get_executor(), [self, item, prepared = std::move(prepared), problem] {
      self->on_prepared(item, prepared, problem);
    });
  });
}

void WebSocketSession::on_prepared(const std::shared_ptr<Item>& item,
                                   std::shared_ptr<PreparedSpeech> prepared,
                                   std::optional<Problem> problem) {
  if (closed_ || closing_ || item->cancelled) return;
  if (problem) {
    const auto it = std::find(pending_.begin(), pending_.end(), item);
    if (it != pending_.end()) {
      pending_.erase(it);
      state_->metrics.speak_queue_depth.fetch_sub(1);
    }
    send_error(item->request.id, *problem);
    start_next();
    return;
  }
  item->prepared = std::move(prepared);
  start_next();
}

void WebSocketSession::start_next() {
  if (active_ || closing_ || closed_ || pending_.empty()) return;
  auto& front = pending_.front();
  if (!front->front_at) front->front_at = Clock::now();
  if (!front->prepared) return;  // on_prepared calls again
  auto item = std::move(front);
  pending_.pop_front();
  state_->metrics.speak_queue_depth.fetch_sub(1);
  start_stream(std::move(item));
}

// ---- streaming (strand) -------------------------------------------------------------------------

void WebSocketSession::start_stream(std::shared_ptr<Item> item) {
  const auto& o = state_->options;
  const auto& r = item->request;
  auto s = std::make_unique<Stream>();
  s->p = item->prepared;
  s->item = std::move(item);
  s->id = state_->next_stream.fetch_add(1);
  s->fps = r.fps;
  s->frames_mode = r.output == Output::kFrames;
  s->end_frame = s->p->frames;
  s->names = static_cast<int>(s->p->rig->mapping.shape_names().size());
  s->values = s->names + 3;
  s->last.assign(static_cast<std::size_t>(s->values), 0.0f);
  if (s->p->sample_rate > 0)
    s->audio_chunk =
        std::max<std::size_t>(1, static_cast<std::size_t>(o.audio_chunk * s->p->sample_rate));

  json audio = nullptr;
  if (s->p->sample_rate > 0) {
    audio = {{"format", "pcm_s16le"},
             {"sample_rate", s->p->sample_rate},
             {"channels", 1},
             {"samples", s->p->pcm.size()}};
  }
  send_control(dump({{"type", "stream_start"},
                     {"id", r.id},
                     {"stream", s->id},
                     {"output", s->frames_mode ? "frames" : "weights"},
                     {"fps", s->fps},
                     {"frames", s->p->frames},
                     {"duration", s->p->duration},
                     {"speech_duration", s->p->speech_duration},
                     {"names", s->p->rig->mapping.shape_names()},
                     {"extra", {"headYaw", "headPitch", "headRoll"}},
                     {"audio", audio},
                     {"size", s->frames_mode ? json{r.width, r.height} : json(nullptr)},
                     {"rig", s->p->rig->id},
                     {"lead", o.lead},
                     {"utterance", s->p->utterance}}));
  s->start = Clock::now();
  state_->metrics.active_streams.fetch_add(1);
  state_->metrics.streams_total.fetch_add(1);
  log::info("stream_start", {{"conn", conn_},
                             {"id", r.id},
                             {"stream", s->id},
                             {"frames", s->p->frames},
                             {"duration", s->p->duration}});
  active_ = std::move(s);
  tick();
}

void WebSocketSession::frame_values(Stream& s, int frame, std::vector<float>& out) {
  out.resize(static_cast<std::size_t>(s.values));
  if (s.cancelling && frame >= s.fade_start) {
    // Frame fade_start is one step into the fade, the last fade frame is at rest.
    anim::fade_to_rest(s.fade_from, (frame - s.fade_start + 1) / s.fps, state_->options.cancel_fade,
                       out);
  } else {
    anim::HeadPose head;
    s.p->performance->sample(
        frame / s.fps, std::span<float>(out.data(), static_cast<std::size_t>(s.names)), &head);
    out[static_cast<std::size_t>(s.names)] = head.yaw;
    out[static_cast<std::size_t>(s.names) + 1] = head.pitch;
    out[static_cast<std::size_t>(s.names) + 2] = head.roll;
  }
  s.last = out;
  s.have_last = true;
}

void WebSocketSession::begin_cancel() {
  Stream& s = *active_;
  s.cancelling = true;
  s.fade_start = s.next_frame;
  s.fade_from = s.last;
  const int fade_frames =
      s.have_last ? static_cast<int>(std::ceil(state_->options.cancel_fade * s.fps - 1e-9)) : 0;
  s.end_frame = s.next_frame + fade_frames;
  log::info(
      "cancel",
      {{"conn", conn_}, {"id", s.item->request.id}, {"stream", s.id}, {"at_frame", s.next_frame}});
  tick();
}

void WebSocketSession::tick() {
  if (!active_ || closing_ || closed_) return;
  Stream& s = *active_;
  const auto& o = state_->options;
  const double elapsed = seconds(Clock::now() - s.start);
  // With min_tick > 0 a wake-up also sends what falls due before the next one (never late, at
  // most min_tick early), so a stream writes one message per min_tick instead of one per frame.
  const double ahead = s.frames_mode ? 0.0 : o.min_tick;

  // Audio: one chunk ahead of the frames it belongs to.
  const auto& pcm = s.p->pcm;
  const double rate = s.p->sample_rate;
  if (!s.cancelling) {
    while (s.audio_next < pcm.size() &&
           s.audio_next / rate - o.lead - o.audio_chunk <= elapsed + ahead + kSlack) {
      const std::size_t n = std::min(s.audio_chunk, pcm.size() - s.audio_next);
      auto msg = std::make_shared<const std::string>(
          audio_message(s.id, static_cast<std::uint32_t>(s.audio_next), s.p->sample_rate,
                        pcm.data() + s.audio_next, n));
      enqueue(Out{std::move(msg), OutKind::kAudio, s.id, 0});
      state_->metrics.audio_samples_sent_total.fetch_add(n);
      s.audio_next += n;
    }
  }
  if (s.frames_mode) {
    launch_renders(s, elapsed);
  } else {
    send_weights(s, elapsed + ahead);
  }
  if (!active_) return;  // a render error ended it
  if (s.next_frame >= s.end_frame && s.in_flight.empty()) {
    finish_stream();
    return;
  }
  double next = INFINITY;
  const bool renders_full =
      s.frames_mode && static_cast<int>(s.in_flight.size()) >= o.frames_in_flight;
  if (s.next_frame < s.end_frame && !renders_full) next = s.next_frame / s.fps - o.lead - ahead;
  if (!s.cancelling && s.audio_next < pcm.size())
    next = std::min(next, s.audio_next / rate - o.lead - o.audio_chunk - ahead);
  if (std::isinf(next)) return;  // waiting for renders; on_rendered ticks
  next = std::max(next, elapsed + o.min_tick);
  arm_timer(s.start + from_seconds(next));
}

void WebSocketSession::arm_timer(Clock::time_point when) {
  const unsigned generation = ++timer_generation_;
  timer_.expires_at(when);
  timer_.async_wait([self = shared_from_this(), generation](beast::error_code ec) {
    if (ec || generation != self->timer_generation_) return;
    self->tick();
  });
}

// Sends every frame whose send time (pts - lead) is at or before `horizon` (seconds since start).
void WebSocketSession::send_weights(Stream& s, double horizon) {
  const double lead = state_->options.lead;
  const int first = s.next_frame;
  thread_local std::vector<float> values, frame;
  values.clear();
  while (s.next_frame < s.end_frame && s.next_frame / s.fps - lead <= horizon + kSlack) {
    frame_values(s, s.next_frame, frame);
    values.insert(values.end(), frame.begin(), frame.end());
    ++s.next_frame;
  }
  const int count = s.next_frame - first;
  if (count == 0) return;
  auto msg = std::make_shared<const std::string>(
      weights_message(s.id, static_cast<std::uint32_t>(first), s.fps,
                      static_cast<std::uint32_t>(count), values.data(), values.size()));
  if (!s.first_sent) {
    s.first_sent = true;
    const auto from = std::max(s.item->received, s.item->front_at.value_or(s.item->received));
    state_->metrics.time_to_first_frame_seconds.observe(seconds(Clock::now() - from));
  }
  s.sent += count;
  enqueue(Out{std::move(msg), OutKind::kWeights, s.id, static_cast<std::uint32_t>(count)});
}

void WebSocketSession::launch_renders(Stream& s, double elapsed) {
  const auto& o = state_->options;
  while (s.next_frame < s.end_frame && static_cast<int>(s.in_flight.size()) < o.frames_in_flight &&
         s.next_frame / s.fps - o.lead <= elapsed + kSlack) {
    if (media_queued_ >= o.write_queue) {  // the client is not reading: skip (late or not)
      ++s.dropped;
      ++s.next_frame;
      state_->metrics.jpeg_frames_dropped_total.fetch_add(1);
      mark_stalled();
      continue;
    }
    // A frame is useless once the next frame's presentation time has passed: skip it.
    if ((s.next_frame + 1) / s.fps < elapsed && s.next_frame + 1 < s.end_frame) {
      log::debug("frame_skipped", {{"conn", conn_},
                                   {"stream", s.id},
                                   {"frame", s.next_frame},
                                   {"late_s", elapsed - s.next_frame / s.fps}});
      ++s.dropped;
      ++s.next_frame;
      state_->metrics.jpeg_frames_dropped_total.fetch_add(1);
      continue;
    }
    const int frame = s.next_frame++;
    std::vector<float> values;
    frame_values(s, frame, values);
    const std::size_t n = static_cast<std::size_t>(s.names);
    const anim::HeadPose head{values[n], values[n + 1], values[n + 2]};
    values.resize(n);  // the renderer takes the shapes, and the head pose apart
    s.in_flight.push_back(Stream::Render{frame, false, nullptr});
    net::post(state_->workers, [self = shared_from_this(), renderer = s.p->renderer,
                                values = std::move(values), head, stream = s.id, frame, fps = s.fps,
                                quality = o.jpeg_quality] {
      std::shared_ptr<const std::string> msg;
      std::optional<Problem> problem;
      try {
        const auto t0 = Clock::now();
        const render::Image image = renderer->render(values, head);
        const std::string jpeg = render::encode_jpeg(image, quality);
        msg = std::make_shared<const std::string>(
            jpeg_message(stream, static_cast<std::uint32_t>(frame), fps, jpeg));
        self->state_->metrics.render_seconds.observe(seconds(Clock::now() - t0));
      } catch (...) {
        problem = describe(std::current_exception());
      }
      net::post(self->ws_.get_executor(), [self, stream, frame, msg = std::move(msg), problem] {
        self->on_rendered(stream, frame, msg, problem);
      });
    });
  }
}

void WebSocketSession::on_rendered(std::uint32_t stream, int frame,
                                   std::shared_ptr<const std::string> message,
                                   std::optional<Problem> problem) {
  if (!active_ || active_->id != stream || closing_ || closed_) return;
  Stream& s = *active_;
  for (auto& r : s.in_flight) {
    if (r.frame == frame) {
      r.done = true;
      r.message = std::move(message);
    }
  }
  if (problem && !s.render_error) s.render_error = problem;
  while (!s.in_flight.empty() && s.in_flight.front().done) {
    auto r = std::move(s.in_flight.front());
    s.in_flight.pop_front();
    if (!r.message) continue;
    if (media_queued_ >= state_->options.write_queue) {
      ++s.dropped;
      state_->metrics.jpeg_frames_dropped_total.fetch_add(1);
      mark_stalled();
      continue;
    }
    if (!s.first_sent) {
      s.first_sent = true;
      const auto from = std::max(s.item->received, s.item->front_at.value_or(s.item->received));
      state_->metrics.time_to_first_frame_seconds.observe(seconds(Clock::now() - from));
    }
    ++s.sent;
    enqueue(Out{std::move(r.message), OutKind::kJpeg, s.id, 1});
  }
  if (s.render_error) {
    // Rendering failed (GL): report it and end the stream with what was sent.
    const Problem p = *s.render_error;
    s.render_error.reset();
    send_error(s.item->request.id, p);
    s.end_frame = s.next_frame;
    if (s.in_flight.empty()) {
      finish_stream();
      return;
    }
  }
  tick();
}

void WebSocketSession::finish_stream() {
  Stream& s = *active_;
  send_control(dump({{"type", "stream_end"},
                     {"id", s.item->request.id},
                     {"stream", s.id},
                     {"frames", s.sent},
                     {"dropped", s.dropped},
                     {"cancelled", s.cancelling}}));
  if (s.frames_mode) {
    state_->metrics.jpeg_frames_sent_total.fetch_add(static_cast<std::uint64_t>(s.sent));
  } else {
    state_->metrics.weights_frames_sent_total.fetch_add(static_cast<std::uint64_t>(s.sent));
  }
  if (s.cancelling) state_->metrics.streams_cancelled_total.fetch_add(1);
  log::info("stream_end", {{"conn", conn_},
                           {"id", s.item->request.id},
                           {"stream", s.id},
                           {"frames", s.sent},
                           {"dropped", s.dropped},
                           {"cancelled", s.cancelling}});
  active_.reset();
  ++timer_generation_;  // a pending wake-up is for the old stream
  state_->metrics.active_streams.fetch_sub(1);
  start_next();
}

// ---- writing
// ---------------------------------------------------------------------------------------

void WebSocketSession::send_control(std::string text) {
  enqueue(Out{std::make_shared<const std::string>(std::move(text)), OutKind::kControl, 0, 0});
}

void WebSocketSession::enqueue(Out out) {
  if (closing_ || closed_) return;
  const bool media = out.kind != OutKind::kControl;
  if (!media) {
    // Control messages are never dropped, but a client that sends requests without reading the
    // answers must not grow the queue without bound.
    const int control = static_cast<int>(queue_.size()) - media_queued_;
    if (control >= 16 * state_->options.write_queue) {
      state_->metrics.slow_clients_closed_total.fetch_add(1);
      log::warn("slow_client", {{"conn", conn_}, {"remote", remote_}, {"queued", queue_.size()}});
      close_with(websocket::close_code::policy_error, "slow client: messages not read");
      return;
    }
    if (control >= state_->options.write_queue) mark_stalled();
  }
  if (media && media_queued_ >= state_->options.write_queue && out.kind == OutKind::kWeights) {
    // Drop the oldest queued weights of this stream (not the one being written).
    const std::size_t from = writing_ ? 1 : 0;
    auto victim = queue_.end();
    for (auto it = queue_.begin() + static_cast<std::ptrdiff_t>(from); it != queue_.end(); ++it) {
      if (it->kind == OutKind::kWeights && it->stream == out.stream) {
        victim = it;
        break;
      }
    }
    Stream* s = active_ && active_->id == out.stream ? active_.get() : nullptr;
    if (victim != queue_.end()) {
      if (s) {
        s->dropped += static_cast<int>(victim->frames);
        s->sent -= static_cast<int>(victim->frames);
      }
      state_->metrics.weights_frames_dropped_total.fetch_add(victim->frames);
      queue_.erase(victim);
      --media_queued_;
      state_->metrics.write_queue_depth.fetch_sub(1);
    } else {
      if (s) {
        s->dropped += static_cast<int>(out.frames);
        s->sent -= static_cast<int>(out.frames);
      }
      state_->metrics.weights_frames_dropped_total.fetch_add(out.frames);
      mark_stalled();
      return;
    }
    mark_stalled();
  }
  if (media) ++media_queued_;
  queue_.push_back(std::move(out));
  state_->metrics.write_queue_depth.fetch_add(1);
  if (!writing_) do_write();
}

void WebSocketSession::do_write() {
  writing_ = true;
  const Out& front = queue_.front();
  ws_.text(front.kind == OutKind::kControl);
  ws_.async_write(net::buffer(*front.data),
                  beast::bind_front_handler(&WebSocketSession::on_write, shared_from_this()));
}

void WebSocketSession::on_write(beast::error_code ec, std::size_t bytes) {
  writing_ = false;
  if (queue_.empty()) return;  // cleared by close
  if (queue_.front().kind != OutKind::kControl) --media_queued_;
  queue_.pop_front();
  state_->metrics.write_queue_depth.fetch_sub(1);
  if (ec) {
    log::debug("ws_write_failed", {{"conn", conn_}, {"error", ec.message()}});
    return;  // the read fails too and cleans up
  }
  state_->metrics.ws_bytes_sent_total.fetch_add(bytes);
  if (queue_.empty()) stalled_since_.reset();
  if (!queue_.empty() && !closing_) do_write();
}

void WebSocketSession::mark_stalled() {
  if (stalled_since_) return;
  stalled_since_ = Clock::now();
  watchdog_.expires_at(*stalled_since_ + from_seconds(state_->options.slow_client_grace));
  watchdog_.async_wait([self = shared_from_this()](beast::error_code ec) {
    if (!ec) self->on_watchdog();
  });
}

void WebSocketSession::on_watchdog() {
  if (!stalled_since_ || closing_ || closed_) return;
  const auto deadline = *stalled_since_ + from_seconds(state_->options.slow_client_grace);
  if (Clock::now() + std::chrono::milliseconds(1) < deadline) {
    watchdog_.expires_at(deadline);
    watchdog_.async_wait([self = shared_from_this()](beast::error_code ec) {
      if (!ec) self->on_watchdog();
    });
    return;
  }
  state_->metrics.slow_clients_closed_total.fetch_add(1);
  log::warn("slow_client", {{"conn", conn_},
                            {"remote", remote_},
                            {"queued", queue_.size()},
                            {"grace_s", state_->options.slow_client_grace}});
  close_with(websocket::close_code::policy_error, "slow client: messages not read");
}

// ---- closing -----------------------------------------------------------------------------------

void WebSocketSession::clear_streams() {
  ++timer_generation_;
  beast::error_code ignored;
  timer_.cancel();
  if (active_) {
    active_.reset();
    state_->metrics.active_streams.fetch_sub(1);
  }
  for (auto& i : pending_) i->cancelled = true;
  state_->metrics.speak_queue_depth.fetch_sub(static_cast<long>(pending_.size()));
  pending_.clear();
}

void WebSocketSession::close_with(websocket::close_code code, const char* reason) {
  if (closing_ || closed_) return;
  closing_ = true;
  clear_streams();
  // Keep only the message being written; the close frame follows it.
  const std::size_t keep = writing_ ? 1 : 0;
  while (queue_.size() > keep) {
    if (queue_.back().kind != OutKind::kControl) --media_queued_;
    queue_.pop_back();
    state_->metrics.write_queue_depth.fetch_sub(1);
  }
  watchdog_.cancel();
  log::info("ws_closing", {{"conn", conn_}, {"code", static_cast<int>(code)}, {"reason", reason}});
  ws_.async_close(
      websocket::close_reason(code, reason), [self = shared_from_this()](beast::error_code ec) {
        if (ec) log::debug("ws_close_failed", {{"conn", self->conn_}, {"error", ec.message()}});
      });
  // A peer that reads nothing never lets the close frame out: end it the hard way.
  close_timer_.expires_after(from_seconds(state_->options.close_timeout));
  close_timer_.async_wait([self = shared_from_this()](beast::error_code ec) {
    if (ec || self->closed_) return;
    log::info("ws_close_timeout", {{"conn", self->conn_}});
    beast::get_lowest_layer(self->ws_).close();
  });
}

void WebSocketSession::on_closed() {
  if (closed_) return;
  closed_ = true;
  clear_streams();
  watchdog_.cancel();
  close_timer_.cancel();
  const auto reason = ws_.reason();
  log::info("ws_closed", {{"conn", conn_}, {"code", static_cast<int>(reason.code)}});
  state_->remove_session(id_);
}

}  // namespace facecast::server
