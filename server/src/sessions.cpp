#include "sessions.hpp"

#include <vector>

namespace facecast::server {

void Sessions::add(std::uint64_t id, std::weak_ptr<Closable> session) {
  std::lock_guard lock(mutex_);
  sessions_[id] = std::move(session);
}

void Sessions::remove(std::uint64_t id) {
  std::lock_guard lock(mutex_);
  sessions_.erase(id);
}

void Sessions::shut_down_all() {
  std::vector<std::shared_ptr<Closable>> live;
  {
    std::lock_guard lock(mutex_);
    for (auto& [id, weak] : sessions_)
      if (auto s = weak.lock()) live.push_back(std::move(s));
  }
  for (auto& s : live) s->shut_down();
}

}  // namespace facecast::server
