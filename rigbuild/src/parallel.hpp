#pragma once
// Work over all cores with plain threads, private to rigbuild. An exception thrown by a worker is
// rethrown on the calling thread after every worker has stopped.
#include <algorithm>
#include <exception>
#include <thread>
#include <vector>

namespace facecast::rigbuild {

/// Runs fn(w) for w in [0, workers) on `workers` threads.
template <typename Fn>
void parallel_workers(unsigned workers, Fn&& fn) {
  std::vector<std::thread> pool;
  std::vector<std::exception_ptr> errors(workers);
  for (unsigned w = 0; w < workers; ++w) {
    pool.emplace_back([&, w] {
      try {
        fn(w);
      } catch (...) {
        errors[w] = std::current_exception();
      }
    });
  }
  for (auto& t : pool) t.join();
  for (auto& e : errors) {
    if (e) std::rethrow_exception(e);
  }
}

/// How many workers `n` items need: at most one per core.
inline unsigned worker_count(std::size_t n) {
  return static_cast<unsigned>(
      std::max<std::size_t>(1, std::min<std::size_t>(std::thread::hardware_concurrency(), n)));
}

/// Runs fn(i) for i in [0, n), items interleaved over the cores.
template <typename Index, typename Fn>
void parallel_for(Index n, Fn&& fn) {
  const unsigned workers = worker_count(static_cast<std::size_t>(n));
  parallel_workers(workers, [&](unsigned w) {
    for (Index i = static_cast<Index>(w); i < n; i += static_cast<Index>(workers)) fn(i);
  });
}

}  // namespace facecast::rigbuild
