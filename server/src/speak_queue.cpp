#include "speak_queue.hpp"

#include <algorithm>
#include <cstdio>

#include "log.hpp"
#include "text_pieces.hpp"
#include "vmc_out.hpp"

namespace facecast::server {

struct SpeakQueue::Item {
  SpeakRequest request;
  Clock::time_point received;
  std::optional<Clock::time_point> front_at;  // reached the front with nothing playing
  std::uint32_t seed = 1;
  bool cancelled = false;
  std::shared_ptr<PreparedSpeech> prepared;
  // Incremental text (request.more): text not yet in a piece, complete pieces not yet prepared,
  // prepared pieces waiting for the stream to start.
  std::optional<TextPieces> text;
  std::deque<std::string> pieces;
  std::deque<std::shared_ptr<PreparedSpeech>> ready;
  bool ended = false, preparing = false;
  int spoken = 0;  // pieces prepared so far
};

SpeakQueue::SpeakQueue(std::shared_ptr<const StreamServices> services, net::any_io_executor strand,
                       StreamSink& sink, std::string conn, std::uint64_t conn_id)
    : services_(std::move(services)),
      strand_(std::move(strand)),
      sink_(sink),
      conn_(std::move(conn)),
      conn_id_(conn_id),
      waiting_(services_->metrics.speak_queue_depth),
      tokens_(services_->options.speak_burst) {}

SpeakQueue::~SpeakQueue() {
  close();
}

void SpeakQueue::take_tokens(Clock::time_point now) {
  const auto& o = services_->options;
  tokens_ = std::min<double>(o.speak_burst,
                             tokens_ + seconds(now - tokens_at_) * o.speak_per_minute / 60.0);
  tokens_at_ = now;
  if (tokens_ < 1.0) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "speak: more than %g per minute (burst %d); wait and retry",
                  o.speak_per_minute, o.speak_burst);
    throw RequestError(Code::kRateLimited, buf);
  }
}

void SpeakQueue::speak(SpeakRequest&& request) {
  const auto now = Clock::now();
  if (services_->sessions.stopping)
    throw RequestError(Code::kUnavailable, "speak: the server is shutting down (draining)");
  take_tokens(now);
  if (const auto n = queued(); static_cast<int>(n) >= services_->options.max_queued_speaks) {
    throw RequestError(Code::kLimit, "speak: " + std::to_string(n) +
                                         " utterances are playing or queued (max_queued_speaks)");
  }
  const auto same_id = [&](const std::shared_ptr<Item>& i) { return i->request.id == request.id; };
  if ((active_ && active_->id() == request.id) ||
      std::any_of(pending_.begin(), pending_.end(), same_id))
    throw Error("id: '" + request.id + "' is already playing or queued");
  const std::string rig = services_->rigs.existing(request.rig).id;
  if (!request.vmc.empty() && !services_->options.vmc_targets.contains(request.vmc))
    throw Error("vmc: '" + request.vmc + "' is not one of the server's vmc_targets");
  tokens_ -= 1.0;

  auto item = std::make_shared<Item>();
  item->request = std::move(request);
  item->received = now;
  item->seed =
      services_->sessions.peek_stream_id() ^ static_cast<std::uint32_t>(conn_id_ * 2654435761u);
  pending_.push_back(item);
  waiting_.set(static_cast<long>(pending_.size()));
  log::info("speak", {{"conn", conn_},
                      {"id", item->request.id},
                      {"rig", rig},
                      {"output", item->request.output == Output::kFrames ? "frames" : "weights"},
                      {"fps", item->request.fps},
                      {"audio", item->request.audio},
                      {"queued", queued() - 1}});
  if (item->request.more) {
    item->text.emplace(services_->options.max_text, services_->options.max_piece);
    for (auto& piece : item->text->add(*item->request.text, "text"))
      item->pieces.push_back(std::move(piece));
    item->request.text->clear();
    prepare_piece(item);
  } else {
    prepare(item, item->request, item->seed, &SpeakQueue::on_prepared);
  }
  start_next();
}

void SpeakQueue::speak_prepared(SpeakRequest&& request, std::shared_ptr<PreparedSpeech> prepared) {
  if (closed_) return;
  auto item = std::make_shared<Item>();
  item->request = std::move(request);
  item->received = Clock::now();
  item->prepared = std::move(prepared);
  pending_.push_back(std::move(item));
  waiting_.set(static_cast<long>(pending_.size()));
  start_next();
}

void SpeakQueue::cancel(const CancelRequest& request) {
  if (active_ && active_->id() == request.id) {
    active_item_->cancelled = true;  // no more pieces
    active_->cancel();
    return;
  }
  const auto it = std::find_if(pending_.begin(), pending_.end(),
                               [&](const auto& i) { return i->request.id == request.id; });
  if (it == pending_.end())
    throw Error("cancel: no utterance '" + request.id + "' is playing or queued",
                ErrorCode::kNotFound);
  (*it)->cancelled = true;
  remove(it);
  log::info("cancelled_queued", {{"conn", conn_}, {"id", request.id}});
  sink_.send(
      OutMessage::control(stream_end_message(StreamEnd{request.id, std::nullopt, 0, 0, true})));
}

void SpeakQueue::close() {
  if (closed_) return;
  closed_ = true;
  if (active_) {
    active_->stop();
    active_.reset();
  }
  if (active_item_) active_item_->cancelled = true;
  active_item_.reset();
  for (auto& i : pending_) i->cancelled = true;
  pending_.clear();
  waiting_.set(0);
}

void SpeakQueue::remove(std::deque<std::shared_ptr<Item>>::iterator it) {
  pending_.erase(it);
  waiting_.set(static_cast<long>(pending_.size()));
}

// ---- preparation (worker pool) ----------------------------------------------------------------

// Prepares `request` on the worker pool; `done` gets the result (or the problem) on the strand.
void SpeakQueue::prepare(const std::shared_ptr<Item>& item, SpeakRequest request,
                         std::uint32_t seed, Done done) {
  net::post(services_->workers,
            [self = shared_from_this(), item, request = std::move(request), seed, done] {
              std::shared_ptr<PreparedSpeech> prepared;
              std::optional<Problem> problem;
              try {
                prepared = self->services_->speech.prepare(request, seed);
              } catch (...) {
                problem = describe(std::current_exception());
              }
              net::post(self->strand_, [self, item, prepared = std::move(prepared), problem, done] {
                ((*self).*done)(item, prepared, problem);
              });
            });
}

void SpeakQueue::on_prepared(const std::shared_ptr<Item>& item,
                             std::shared_ptr<PreparedSpeech> prepared,
                             std::optional<Problem> problem) {
  if (closed_ || item->cancelled) return;
  if (problem) {
    if (const auto it = std::find(pending_.begin(), pending_.end(), item); it != pending_.end())
      remove(it);
    sink_.send_error(item->request.id, *problem);
    start_next();
    return;
  }
  item->prepared = std::move(prepared);
  start_next();
}

// ---- streaming ----------------------------------------------------------------------------------

// Streams the front utterance once nothing plays and it is prepared.
void SpeakQueue::start_next() {
  if (active_ || closed_ || pending_.empty()) return;
  auto& front = pending_.front();
  if (!front->front_at) front->front_at = Clock::now();
  if (!front->prepared) return;  // on_prepared calls again
  const std::shared_ptr<Item> item = std::move(front);
  remove(pending_.begin());
  const auto asked_at = std::max(item->received, *item->front_at);
  const bool open = item->request.more;
  active_item_ = item;
  // Mirrored to a VMC receiver: the tee lives as long as the pacer (its end callback holds it)
  // and its own timer.
  std::shared_ptr<VmcTee> tee;
  if (!item->request.vmc.empty())
    tee = std::make_shared<VmcTee>(strand_, sink_,
                                   services_->options.vmc_targets.at(item->request.vmc), conn_);
  active_ = std::make_shared<StreamPacer>(
      services_, strand_, tee ? static_cast<StreamSink&>(*tee) : sink_, conn_, item->request,
      std::move(item->prepared), asked_at, [this, tee] { on_stream_end(); }, open);
  active_->start();
  if (!open || active_item_ != item) return;
  for (auto& piece : item->ready) active_->append(std::move(piece));
  item->ready.clear();
  close_if_done(item);
}

void SpeakQueue::on_stream_end() {
  active_.reset();
  active_item_.reset();
  start_next();
}

// ---- incremental text ---------------------------------------------------------------------------

std::shared_ptr<SpeakQueue::Item> SpeakQueue::open_item(const std::string& id, const char* what) {
  std::shared_ptr<Item> item;
  if (active_item_ && active_item_->request.id == id) item = active_item_;
  for (const auto& i : pending_) {
    if (i->request.id == id) item = i;
  }
  if (!item)
    throw Error(std::string(what) + ": no utterance '" + id + "' is playing or queued",
                ErrorCode::kNotFound);
  if (!item->request.more)
    throw Error(std::string(what) + ": utterance '" + id +
                "' is not open (speak with \"more\": true)");
  if (item->ended || item->cancelled)
    throw Error(std::string(what) + ": utterance '" + id + "' has ended");
  return item;
}

void SpeakQueue::append(const AppendRequest& request) {
  const auto item = open_item(request.id, "append");
  for (auto& piece : item->text->add(request.text, "append"))
    item->pieces.push_back(std::move(piece));
  prepare_piece(item);
}

void SpeakQueue::end(const EndRequest& request) {
  const auto item = open_item(request.id, "end");
  item->ended = true;
  for (auto& piece : item->text->finish()) item->pieces.push_back(std::move(piece));
  if (item->spoken == 0 && item->pieces.empty() && !item->preparing) {
    // Nothing was said: the utterance ends without a stream.
    if (const auto it = std::find(pending_.begin(), pending_.end(), item); it != pending_.end())
      remove(it);
    sink_.send(
        OutMessage::control(stream_end_message(StreamEnd{request.id, std::nullopt, 0, 0, false})));
    start_next();
    return;
  }
  prepare_piece(item);
  close_if_done(item);
}

// One piece at a time, in order, on the worker pool.
void SpeakQueue::prepare_piece(const std::shared_ptr<Item>& item) {
  if (item->preparing || item->pieces.empty() || item->cancelled) return;
  item->preparing = true;
  SpeakRequest piece = item->request;
  piece.text = std::move(item->pieces.front());
  item->pieces.pop_front();
  const std::uint32_t seed = item->seed + static_cast<std::uint32_t>(item->spoken);
  prepare(item, std::move(piece), seed, &SpeakQueue::on_piece);
}

void SpeakQueue::on_piece(const std::shared_ptr<Item>& item,
                          std::shared_ptr<PreparedSpeech> prepared,
                          std::optional<Problem> problem) {
  item->preparing = false;
  if (closed_ || item->cancelled) return;
  if (problem) {
    sink_.send_error(item->request.id, *problem);  // that piece is left out
  } else if (++item->spoken == 1) {
    item->prepared = std::move(prepared);
  } else if (active_item_ == item) {
    active_->append(std::move(prepared));
  } else {
    item->ready.push_back(std::move(prepared));
  }
  prepare_piece(item);
  if (item->spoken == 0 && item->ended && item->pieces.empty() && !item->preparing) {
    if (const auto it = std::find(pending_.begin(), pending_.end(), item); it != pending_.end())
      remove(it);
    sink_.send(OutMessage::control(
        stream_end_message(StreamEnd{item->request.id, std::nullopt, 0, 0, false})));
  }
  start_next();
  close_if_done(item);
}

// The open stream ends once `end` came and every piece is in it.
void SpeakQueue::close_if_done(const std::shared_ptr<Item>& item) {
  if (active_item_ != item || !item->ended || item->preparing || !item->pieces.empty() ||
      !item->ready.empty())
    return;
  active_->close_text();
}

}  // namespace facecast::server
