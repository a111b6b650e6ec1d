// ThreadBudget: threads taken without blocking and given back; a ThreadBudgetScope holds the
// caller's thread for its lifetime (waiting when all are taken) and marks the budget as the
// calling thread's own; the parallel loops that hold one budget run on at most its threads
// together (the server's job_workers), nested loops inline.
#include <catch2/catch.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include "facecast/core/threads.hpp"

using namespace facecast;

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

TEST_CASE("a thread budget lends what it has and never more", "[core][threads]") {
  ThreadBudget budget(3);
  CHECK(budget.acquire(2) == 2);
  CHECK(budget.available() == 1);
  CHECK(budget.acquire(5) == 1);  // what is left
  CHECK(budget.acquire(1) == 0);  // none: it does not wait
  budget.release(3);
  CHECK(budget.available() == 3);
}

TEST_CASE("a budget scope holds the caller's thread and is the caller's own", "[core][threads]") {
  ThreadBudget budget(2);
  CHECK(current_thread_budget() == nullptr);
  {
    const ThreadBudgetScope scope(budget);
    CHECK(current_thread_budget() == &budget);
    CHECK(budget.available() == 1);
    ThreadBudget* elsewhere = &budget;
    std::thread([&] { elsewhere = current_thread_budget(); }).join();
    CHECK(elsewhere == nullptr);  // another thread runs outside it
  }
  CHECK(current_thread_budget() == nullptr);
  CHECK(budget.available() == 2);
}

TEST_CASE("a budget scope waits while every thread of the budget is held", "[core][threads]") {
  ThreadBudget budget(1);
  std::atomic<bool> entered{false};
  std::thread other;
  {
    const ThreadBudgetScope scope(budget);
    other = std::thread([&] {
      const ThreadBudgetScope second(budget);
      entered = true;
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    CHECK_FALSE(entered);
  }
  other.join();
  CHECK(entered);
  CHECK(budget.available() == 1);
}

TEST_CASE("a thread budget bounds the threads of the parallel loops that hold it",
          "[core][threads]") {
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
}

TEST_CASE("without a budget, loops use the cores and errors reach the caller", "[core][threads]") {
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
