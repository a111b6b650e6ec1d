// ThreadBudget: threads taken without blocking and given back; a ThreadBudgetScope holds the
// caller's thread for its lifetime (waiting when all are taken) and marks the budget as the
// calling thread's own. The loops that borrow from it are tested with them (tests/rigbuild).
#include <catch2/catch.hpp>

#include <atomic>
#include <chrono>
#include <thread>

#include "facecast/core/threads.hpp"

using facecast::current_thread_budget;
using facecast::ThreadBudget;
using facecast::ThreadBudgetScope;

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
