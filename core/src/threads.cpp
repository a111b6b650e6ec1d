#include "facecast/core/threads.hpp"

#include <chrono>
#include <thread>

namespace facecast {
namespace {
thread_local ThreadBudget* t_budget = nullptr;
thread_local bool t_in_worker = false;
}  // namespace

unsigned ThreadBudget::acquire(unsigned wanted) noexcept {
  unsigned have = free_.load();
  for (;;) {
    const unsigned take = have < wanted ? have : wanted;
    if (take == 0) return 0;
    if (free_.compare_exchange_weak(have, have - take)) return take;
  }
}

void ThreadBudget::release(unsigned count) noexcept {
  free_.fetch_add(count);
}

ThreadBudgetScope::ThreadBudgetScope(ThreadBudget& budget) : budget_(budget) {
  // The caller's own thread: work beyond the budget waits here for a running one to end.
  while (budget_.acquire(1) == 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  t_budget = &budget_;
}

ThreadBudgetScope::ThreadBudgetScope(ThreadBudget& budget, std::adopt_lock_t) noexcept
    : budget_(budget) {
  t_budget = &budget_;
}

ThreadBudgetScope::~ThreadBudgetScope() {
  t_budget = nullptr;
  budget_.release(1);
}

ThreadBudget* current_thread_budget() noexcept {
  return t_budget;
}

WorkerLease::WorkerLease(std::size_t n) {
  const std::size_t useful = std::max<std::size_t>(1, n);
  if (t_in_worker) {
    workers_ = 1;  // a loop inside a loop's worker runs on that worker
  } else if (ThreadBudget* b = current_thread_budget()) {
    const std::size_t extra = std::min<std::size_t>(useful - 1, 63);
    borrowed_ = b->acquire(static_cast<unsigned>(extra));
    budget_ = b;
    workers_ = 1 + borrowed_;
  } else {
    workers_ = static_cast<unsigned>(
        std::min<std::size_t>(std::max(1u, std::thread::hardware_concurrency()), useful));
  }
}

WorkerLease::~WorkerLease() {
  if (budget_) budget_->release(borrowed_);
}

WorkerScope::WorkerScope() : previous_(t_in_worker) {
  t_in_worker = true;
}

WorkerScope::~WorkerScope() {
  t_in_worker = previous_;
}

}  // namespace facecast
