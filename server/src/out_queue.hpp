#pragma once
// The outgoing messages of one WebSocket connection, in order: the first writing() of them are
// being written (one gather write), the rest wait here. The queue owns its share of the
// write_queue_depth gauge and applies the drop-oldest rule for weights (see
// docs/algorithms.md#stream-pacing):
//
//   when `media_limit` media messages are waiting, a new weights message replaces the oldest
//   queued weights message of its stream (never one being written); when there is none it
//   waits beyond the limit (one per stream at most: the stream's next replaces it), so the
//   newest frames always go out. Control messages, audio and JPEG frames are never dropped here.
#include <atomic>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>

#include "metrics.hpp"

namespace facecast::server {

enum class OutKind { kControl, kAudio, kWeights, kJpeg };
/// stream_start / stream_end control messages are marked, so a channel knows what is on air.
enum class Boundary : std::uint8_t { kNone, kStart, kEnd };

/// One message to send: a control message (JSON text) or a binary media message.
struct OutMessage {
  std::shared_ptr<const std::string> data;
  OutKind kind = OutKind::kControl;
  std::uint32_t stream = 0;
  std::uint32_t frames = 0;  // media frames in it (weights, JPEG)
  Boundary boundary = Boundary::kNone;

  bool media() const noexcept { return kind != OutKind::kControl; }
  static OutMessage control(std::string text) {
    return OutMessage{std::make_shared<const std::string>(std::move(text)), OutKind::kControl, 0, 0,
                      Boundary::kNone};
  }
};

class OutQueue {
 public:
  OutQueue(std::atomic<long>& depth_gauge, int media_limit);

  bool empty() const noexcept { return queue_.empty(); }
  std::size_t size() const noexcept { return queue_.size(); }
  int control() const noexcept { return static_cast<int>(queue_.size()) - media_; }
  /// True when `media_limit` media messages are waiting.
  bool media_full() const noexcept { return media_ >= limit_; }

  struct Pushed {
    std::uint32_t dropped_frames = 0;  // of the older weights message it replaced
  };
  /// Appends `message`, applying the drop-oldest rule to weights.
  Pushed push(OutMessage message);

  /// How many messages, from the front, are being written (0: none).
  std::size_t writing() const noexcept { return writing_; }
  /// Marks up to `most` queued messages as being written, returns how many; they stay at the
  /// front until finish_write().
  std::size_t start_write(std::size_t most);
  const OutMessage& operator[](std::size_t i) const { return queue_[i]; }
  /// Removes the messages that were being written.
  void finish_write();
  /// Forgets every message but those being written (the connection is closing).
  void drop_unsent();

 private:
  void remove(std::deque<OutMessage>::iterator it);

  std::deque<OutMessage> queue_;
  std::size_t writing_ = 0;
  int media_ = 0;
  int limit_;
  GaugeShare depth_;  // = queue_.size()
};

}  // namespace facecast::server
