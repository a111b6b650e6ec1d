#include "facecast/rigbuild/threads.hpp"

#include <omp.h>

#include <chrono>
#include <thread>

#include "parallel.hpp"

namespace facecast::rigbuild {
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

ThreadBudgetScope::ThreadBudgetScope(ThreadBudget& budget)
    : budget_(budget), previous_omp_threads_(omp_get_max_threads()) {
  // The caller's own thread: builds beyond the budget wait here for a running one to end.
  while (budget_.acquire(1) == 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  t_budget = &budget_;
  // OpenMP regions started on this thread (CHOLMOD's supernodal factorization) get one thread
  // unless a loop lends them more (OpenMpThreads); the setting is this thread's own ICV.
  omp_set_num_threads(1);
}

ThreadBudgetScope::~ThreadBudgetScope() {
  omp_set_num_threads(previous_omp_threads_);
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
  } else if (ThreadBudget* b = t_budget) {
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

OpenMpThreads::OpenMpThreads() : previous_(omp_get_max_threads()) {
  if (!t_budget) return;
  lease_.emplace(static_cast<std::size_t>(std::max(1u, std::thread::hardware_concurrency())));
  omp_set_num_threads(static_cast<int>(lease_->workers()));
}

OpenMpThreads::~OpenMpThreads() {
  omp_set_num_threads(previous_);
}

}  // namespace facecast::rigbuild
