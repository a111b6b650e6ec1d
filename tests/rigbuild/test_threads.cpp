// ThreadBudget: the parallel loops of rig builds that hold one budget run on at most its threads
// together (the server's job_workers), nested loops run inline, OpenMP regions are lent threads.
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <catch2/catch.hpp>
#include <chrono>
#include <thread>

#include "facecast/rigbuild/threads.hpp"
#include "parallel.hpp"

using namespace facecast::rigbuild;

namespace {

// Counts the items running at once and remembers the most.
struct Concurrency {
  std::atomic<int> now{0}, most{0};
  std::atomic<long> items{0};
  void item() {
    const int n = ++now;
    int m = most.load();
    while (n > m && !most.compare_exchange_weak(m, n)) {
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    ++items;
    --now;
  }
};

}  // namespace

TEST_CASE("a thread budget bounds the threads of the parallel loops that hold it", "[threads]") {
  SECTION("one build") {
    ThreadBudget budget(2);
    Concurrency c;
    {
      const ThreadBudgetScope scope(budget);
      CHECK(current_thread_budget() == &budget);
      parallel_for(64, [&](int) { c.item(); });
      // Nested loops run on the worker that started them.
      parallel_for(8, [&](int) { parallel_for(8, [&](int) { c.item(); }); });
    }
    CHECK(current_thread_budget() == nullptr);
    CHECK(c.items == 64 + 64);
    CHECK(c.most <= 2);
    CHECK(budget.available() == 2);  // everything given back
  }
  SECTION("three builds sharing a budget of two threads") {
    ThreadBudget budget(2);
    Concurrency c;
    std::vector<std::thread> builds;
    for (int b = 0; b < 3; ++b) {
      builds.emplace_back([&] {
        const ThreadBudgetScope scope(budget);  // the third waits for a thread
        parallel_for(40, [&](int) { c.item(); });
      });
    }
    for (auto& t : builds) t.join();
    CHECK(c.items == 3 * 40);
    CHECK(c.most <= 2);
    CHECK(budget.available() == 2);
  }
  SECTION("a budget of one runs everything on the caller") {
    ThreadBudget budget(1);
    const ThreadBudgetScope scope(budget);
    const auto caller = std::this_thread::get_id();
    std::atomic<int> elsewhere{0};
    parallel_for(32, [&](int) { elsewhere += std::this_thread::get_id() != caller; });
    CHECK(elsewhere == 0);
  }
  SECTION("OpenMP regions started under a budget get what it can lend") {
    ThreadBudget budget(2);
    const ThreadBudgetScope scope(budget);
    CHECK(omp_get_max_threads() == 1);
    int team = 0;
    {
      const OpenMpThreads lend;
      CHECK(omp_get_max_threads() <= 2);
#pragma omp parallel
      {
#pragma omp single
        team = omp_get_num_threads();
      }
    }
    CHECK(team >= 1);
    CHECK(team <= 2);
    CHECK(budget.available() == 1);  // the lent thread is back; the scope holds one
  }
}

TEST_CASE("without a budget, loops use the cores and errors reach the caller", "[threads]") {
  CHECK(current_thread_budget() == nullptr);
  std::atomic<long> sum{0};
  parallel_for(1000, [&](int i) { sum += i; });
  CHECK(sum == 999L * 1000 / 2);
  CHECK_THROWS_WITH(parallel_for(10,
                                 [&](int i) {
                                   if (i == 7) throw std::runtime_error("item 7");
                                 }),
                    "item 7");
}
