#include "parallel.hpp"

#include <dlfcn.h>
#include <omp.h>

#include <algorithm>
#include <thread>

namespace facecast::rigbuild {
namespace {

// BLAS (OpenBLAS, under CHOLMOD and dlib's shape predictor) runs on the thread that calls it, as
// OpenMP's regions do under a budget: the parallel work is the loops', which the budget counts.
// Its pthread build is the one that several threads may call at once (install-deps.sh; the serial
// build shares its work buffers between callers without a lock). Looked up at run time, so that
// another BLAS links too.
[[maybe_unused]] const bool blas_on_callers_thread = [] {
  using SetThreads = void (*)(int);
  if (void* set = dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))
    reinterpret_cast<SetThreads>(set)(1);
  return true;
}();

}  // namespace

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
