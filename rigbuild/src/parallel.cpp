#include "parallel.hpp"

#include <omp.h>

#include <thread>

namespace facecast::rigbuild {
namespace {
thread_local bool t_in_worker = false;
}  // namespace

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

OpenMpThreads::OpenMpThreads() : previous_(omp_get_max_threads()) {
  if (!current_thread_budget()) return;
  lease_.emplace(static_cast<std::size_t>(std::max(1u, std::thread::hardware_concurrency())));
  omp_set_num_threads(static_cast<int>(lease_->workers()));
}

OpenMpThreads::~OpenMpThreads() {
  omp_set_num_threads(previous_);
}

OpenMpWithinBudget::OpenMpWithinBudget() : previous_(omp_get_max_threads()) {
  if (current_thread_budget()) omp_set_num_threads(1);
}

OpenMpWithinBudget::~OpenMpWithinBudget() {
  omp_set_num_threads(previous_);
}

}  // namespace facecast::rigbuild
