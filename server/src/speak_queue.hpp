#pragma once
// The utterances of one connection, in order (docs/protocol.md, `speak` and `cancel`): the rate
// limit (a token bucket of speak_burst refilled at speak_per_minute), the queue limit
// (max_queued_speaks, playing + waiting), preparation on the worker pool as soon as a speak
// arrives, and one StreamPacer at a time for the front. Runs on the connection's strand; owns its
// share of the speak_queue_depth gauge.
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>

#include "beast.hpp"
#include "clock.hpp"
#include "stream_pacer.hpp"

namespace facecast::server {

class SpeakQueue : public std::enable_shared_from_this<SpeakQueue> {
 public:
  /// `sink` gets every message until close(); `conn` names the connection in logs.
  SpeakQueue(std::shared_ptr<const StreamServices> services, net::any_io_executor strand,
             StreamSink& sink, std::string conn, std::uint64_t conn_id);
  ~SpeakQueue();

  /// Queues an utterance. Throws RequestError (rate_limited, limit) or Error (a duplicate id, an
  /// unknown rig).
  void speak(SpeakRequest&& request);
  /// Cancels the playing utterance (fade to rest) or a waiting one (`stream_end` at once). Throws
  /// Error (not found) when no utterance `id` is playing or waiting.
  void cancel(const CancelRequest& request);
  /// Stops the playing stream and forgets the waiting ones; nothing is sent after this.
  void close();
  /// Incremental text: adds text to the open utterance `id` (a speak with "more": true) and
  /// speaks each piece as soon as it is complete; end() closes it. Throw Error (not found, not
  /// open, already ended).
  void append(const AppendRequest& request);
  void end(const EndRequest& request);
  /// Something plays or waits.
  bool busy() const noexcept { return active_ || !pending_.empty(); }
  /// Queues an utterance that is already prepared (a channel's idle life): no rate limit.
  void speak_prepared(SpeakRequest&& request, std::shared_ptr<PreparedSpeech> prepared);

 private:
  struct Item;

  void take_tokens(Clock::time_point now);
  using Done = void (SpeakQueue::*)(const std::shared_ptr<Item>&, std::shared_ptr<PreparedSpeech>,
                                    std::optional<Problem>);
  void prepare(const std::shared_ptr<Item>& item, SpeakRequest request, std::uint32_t seed,
               Done done);
  void on_prepared(const std::shared_ptr<Item>& item, std::shared_ptr<PreparedSpeech> prepared,
                   std::optional<Problem> problem);
  void start_next();
  std::shared_ptr<Item> open_item(const std::string& id, const char* what);
  void prepare_piece(const std::shared_ptr<Item>& item);
  void on_piece(const std::shared_ptr<Item>& item, std::shared_ptr<PreparedSpeech> prepared,
                std::optional<Problem> problem);
  void close_if_done(const std::shared_ptr<Item>& item);
  void on_stream_end();
  void remove(std::deque<std::shared_ptr<Item>>::iterator it);
  std::size_t queued() const { return pending_.size() + (active_ ? 1 : 0); }

  std::shared_ptr<const StreamServices> services_;
  net::any_io_executor strand_;
  StreamSink& sink_;
  std::string conn_;
  std::uint64_t conn_id_;
  std::deque<std::shared_ptr<Item>> pending_;  // waiting utterances, in order
  GaugeShare waiting_;                         // speak_queue_depth: pending_.size()
  std::shared_ptr<StreamPacer> active_;
  std::shared_ptr<Item> active_item_;  // the item active_ plays
  double tokens_;
  Clock::time_point tokens_at_ = Clock::now();
  bool closed_ = false;
};

}  // namespace facecast::server
