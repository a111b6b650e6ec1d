#pragma once
// How many threads a program's heavy work may use. By default parallel loops take one thread per
// core; a program that shares the machine (the server: live streams run beside its jobs) gives its
// work a ThreadBudget, and every parallel loop started on a thread that holds the budget borrows
// its extra threads from it, so that all the work holding one budget together runs on at most
// `threads` threads (each holder's own thread counts as one). The loops read
// current_thread_budget() where they start (rigbuild's parallel loops, and its OpenMP regions:
// rigbuild/src/parallel.hpp); the budget itself knows nothing of them.
#include <atomic>
#include <mutex>

namespace facecast {

class ThreadBudget {
 public:
  /// `threads` >= 1: the most threads the holders run on together, their own included.
  explicit ThreadBudget(unsigned threads) noexcept : free_(threads) {}
  ThreadBudget(const ThreadBudget&) = delete;
  ThreadBudget& operator=(const ThreadBudget&) = delete;

  /// Takes up to `wanted` threads (never blocks); returns how many it took.
  unsigned acquire(unsigned wanted) noexcept;
  void release(unsigned count) noexcept;
  /// Threads not taken at this moment.
  unsigned available() const noexcept { return free_.load(); }

 private:
  std::atomic<unsigned> free_;
};

/// For its lifetime, the calling thread runs its work under `budget`: the scope takes one thread
/// from the budget (the caller's own; it waits for one when all are taken) and the parallel loops
/// started on this thread borrow the rest. Scopes do not nest on one thread.
class ThreadBudgetScope {
 public:
  explicit ThreadBudgetScope(ThreadBudget& budget);
  /// Adopts a thread the caller already took from `budget` (acquire(1) returned 1): the scope
  /// gives it back at its end.
  ThreadBudgetScope(ThreadBudget& budget, std::adopt_lock_t) noexcept;
  ~ThreadBudgetScope();
  ThreadBudgetScope(const ThreadBudgetScope&) = delete;
  ThreadBudgetScope& operator=(const ThreadBudgetScope&) = delete;

 private:
  ThreadBudget& budget_;
};

/// The budget the calling thread runs under (nullptr: none, one thread per core).
ThreadBudget* current_thread_budget() noexcept;

}  // namespace facecast
