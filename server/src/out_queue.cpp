#include "out_queue.hpp"

#include <algorithm>

namespace facecast::server {

OutQueue::OutQueue(std::atomic<long>& depth_gauge, int media_limit)
    : limit_(media_limit), depth_(depth_gauge) {}

OutQueue::Pushed OutQueue::push(OutMessage message) {
  Pushed pushed;
  if (message.kind == OutKind::kWeights && media_full()) {
    const auto from = queue_.begin() + (writing_ ? 1 : 0);
    const auto victim = std::find_if(from, queue_.end(), [&](const OutMessage& m) {
      return m.kind == OutKind::kWeights && m.stream == message.stream;
    });
    if (victim == queue_.end()) return Pushed{false, message.frames};
    pushed.dropped_frames = victim->frames;
    remove(victim);
  }
  media_ += message.media();
  queue_.push_back(std::move(message));
  depth_.set(static_cast<long>(queue_.size()));
  return pushed;
}

const OutMessage& OutQueue::start_write() {
  writing_ = true;
  return queue_.front();
}

void OutQueue::finish_write() {
  writing_ = false;
  if (!queue_.empty()) remove(queue_.begin());
}

void OutQueue::drop_unsent() {
  while (queue_.size() > (writing_ ? 1u : 0u)) remove(queue_.end() - 1);
}

void OutQueue::remove(std::deque<OutMessage>::iterator it) {
  media_ -= it->media();
  queue_.erase(it);
  depth_.set(static_cast<long>(queue_.size()));
}

}  // namespace facecast::server
