#include "parallel.hpp"

#include <omp.h>

#include <algorithm>
#include <thread>

namespace facecast::rigbuild {

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
