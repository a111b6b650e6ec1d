#include "facecast/core/threads.hpp"

#include <chrono>
#include <thread>

namespace facecast {
namespace {
thread_local ThreadBudget* t_budget = nullptr;
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

}  // namespace facecast
