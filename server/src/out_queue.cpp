#include "out_queue.hpp"

#include <algorithm>

namespace facecast::server {

OutQueue::OutQueue(std::atomic<long>& depth_gauge, int media_limit)
    : limit_(media_limit), depth_(depth_gauge) {}

OutQueue::Pushed OutQueue::push(OutMessage message) {
  Pushed pushed;
  if (message.kind == OutKind::kWeights && media_full()) {
    const auto from = queue_.begin() + static_cast<std::ptrdiff_t>(writing_);
    const auto victim = std::find_if(from, queue_.end(), [&](const OutMessage& m) {
      return m.kind == OutKind::kWeights && m.stream == message.stream;
    });
    // None waiting (the write in flight holds them all): this one waits beyond the limit, and the
    // stream's next replaces it, so the newest frames still go out.
    if (victim != queue_.end()) {
      pushed.dropped_frames = victim->frames;
      remove(victim);
    }
  }
  media_ += message.media();
  queue_.push_back(std::move(message));
  depth_.set(static_cast<long>(queue_.size()));
  return pushed;
}

std::size_t OutQueue::start_write(std::size_t most) {
  writing_ = std::min(most, queue_.size());
  return writing_;
}

void OutQueue::finish_write() {
  for (std::size_t i = 0; i < writing_; ++i) media_ -= queue_[i].media();
  queue_.erase(queue_.begin(), queue_.begin() + static_cast<std::ptrdiff_t>(writing_));
  writing_ = 0;
  depth_.set(static_cast<long>(queue_.size()));
}

void OutQueue::drop_unsent() {
  while (queue_.size() > writing_) remove(queue_.end() - 1);
}

void OutQueue::remove(std::deque<OutMessage>::iterator it) {
  media_ -= it->media();
  queue_.erase(it);
  depth_.set(static_cast<long>(queue_.size()));
}

}  // namespace facecast::server
