#pragma once
// rigbuild's threads under a ThreadBudget beyond core's parallel loops (facecast/core/threads.hpp):
// OpenMP's regions (CHOLMOD's, and Eigen's large products: rigbuild compiles with OpenMP) follow
// the budget through OpenMpThreads and OpenMpWithinBudget, and work started beside a build's own
// thread through async_within_budget.
#include <future>
#include <mutex>
#include <optional>
#include <type_traits>

#include "facecast/core/threads.hpp"

namespace facecast::rigbuild {

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
