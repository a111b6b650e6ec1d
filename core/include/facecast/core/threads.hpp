#pragma once
// How many threads a program's heavy work may use. By default parallel loops take one thread per
// core; a program that shares the machine (the server: live streams run beside its jobs) gives its
// work a ThreadBudget, and every parallel loop started on a thread that holds the budget borrows
// its extra threads from it, so that all the work holding one budget together runs on at most
// `threads` threads (each holder's own thread counts as one). The loops read
// current_thread_budget() where they start (parallel_for below; rigbuild's OpenMP regions follow it
// through rigbuild/src/parallel.hpp); the budget itself knows nothing of them.
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

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

// Parallel loops over plain threads. An exception thrown by a worker is rethrown on the calling
// thread after every worker has stopped. Under a budget a loop runs on the calling thread plus the
// threads it could borrow; a loop started inside a loop's worker runs on that worker.

/// The workers a loop over `n` items runs on: one per core (at most n), or under a budget the
/// calling thread plus what it could borrow, given back when the lease ends.
class WorkerLease {
 public:
  explicit WorkerLease(std::size_t n);
  ~WorkerLease();
  WorkerLease(const WorkerLease&) = delete;
  WorkerLease& operator=(const WorkerLease&) = delete;
  unsigned workers() const noexcept { return workers_; }

 private:
  ThreadBudget* budget_ = nullptr;
  unsigned borrowed_ = 0;
  unsigned workers_ = 1;
};

/// Marks the calling thread as a loop's worker for its lifetime (nested loops run inline).
class WorkerScope {
 public:
  WorkerScope();
  ~WorkerScope();
  WorkerScope(const WorkerScope&) = delete;
  WorkerScope& operator=(const WorkerScope&) = delete;

 private:
  bool previous_;
};

/// Runs fn(w) for w in [0, workers): w = 0 on the calling thread, the others on new threads.
template <typename Fn>
void parallel_workers(unsigned workers, Fn&& fn) {
  std::vector<std::thread> pool;
  std::vector<std::exception_ptr> errors(workers);
  const auto run = [&](unsigned w) {
    WorkerScope scope;
    try {
      fn(w);
    } catch (...) {
      errors[w] = std::current_exception();
    }
  };
  for (unsigned w = 1; w < workers; ++w) pool.emplace_back(run, w);
  run(0);
  for (auto& t : pool) t.join();
  for (auto& e : errors) {
    if (e) std::rethrow_exception(e);
  }
}

/// Runs fn(i) for i in [0, n), items interleaved over the workers of a WorkerLease.
template <typename Index, typename Fn>
void parallel_for(Index n, Fn&& fn) {
  const WorkerLease lease(static_cast<std::size_t>(n));
  const unsigned workers = lease.workers();
  parallel_workers(workers, [&](unsigned w) {
    for (Index i = static_cast<Index>(w); i < n; i += static_cast<Index>(workers)) fn(i);
  });
}

}  // namespace facecast
