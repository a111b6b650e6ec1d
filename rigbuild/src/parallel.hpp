#pragma once
// Work over the cores with plain threads, private to rigbuild. An exception thrown by a worker is
// rethrown on the calling thread after every worker has stopped. Under a ThreadBudget
// (facecast/core/threads.hpp) a loop runs on the calling thread plus the threads it could borrow;
// a loop started inside a loop's worker runs on that worker. OpenMP's regions (CHOLMOD's, and
// Eigen's large products: rigbuild compiles with OpenMP) follow the budget through OpenMpThreads
// and OpenMpWithinBudget.
#include <algorithm>
#include <cstddef>
#include <exception>
#include <future>
#include <mutex>
#include <optional>
#include <thread>
#include <type_traits>
#include <vector>

#include "facecast/core/threads.hpp"

namespace facecast::rigbuild {

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

/// Around a library call that runs OpenMP regions on this thread (CHOLMOD): under a budget, lends
/// the regions the threads it can borrow; without one, changes nothing.
class OpenMpThreads {
 public:
  OpenMpThreads();
  ~OpenMpThreads();
  OpenMpThreads(const OpenMpThreads&) = delete;
  OpenMpThreads& operator=(const OpenMpThreads&) = delete;

 private:
  int previous_;
  std::optional<WorkerLease> lease_;
};

/// Opened by the entry points that run a whole operation (build_rig, auto_markers,
/// avatar_from_photos): under a budget, the OpenMP regions started on the calling thread get one
/// thread, the caller's own that the budget already counts, unless OpenMpThreads lends them more;
/// without one, changes nothing. OpenMP's thread count is the calling thread's own setting; the
/// scope gives back the one it found.
class OpenMpWithinBudget {
 public:
  OpenMpWithinBudget();
  ~OpenMpWithinBudget();
  OpenMpWithinBudget(const OpenMpWithinBudget&) = delete;
  OpenMpWithinBudget& operator=(const OpenMpWithinBudget&) = delete;

 private:
  int previous_;
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

/// Starts `fn` on another thread, as std::async does, when that stays within the calling thread's
/// budget: without a budget, or with a thread it lends (the new thread then holds it and runs under
/// the budget, its OpenMP regions as OpenMpWithinBudget sets them). When the budget has none free,
/// `fn` is deferred: it runs on the calling thread when its result is asked for.
template <typename Fn>
std::future<std::invoke_result_t<Fn&>> async_within_budget(Fn fn) {
  ThreadBudget* budget = current_thread_budget();
  if (!budget) return std::async(std::launch::async, std::move(fn));
  if (budget->acquire(1) == 0) return std::async(std::launch::deferred, std::move(fn));
  try {
    return std::async(std::launch::async, [budget, fn = std::move(fn)]() mutable {
      const ThreadBudgetScope scope(*budget, std::adopt_lock);
      const OpenMpWithinBudget openmp;
      return fn();
    });
  } catch (...) {  // no thread could be started: the lent one goes back
    budget->release(1);
    throw;
  }
}

}  // namespace facecast::rigbuild
