#pragma once
// bench_server --hostile: clients that attack the server while the measured ones stream.
#include <atomic>
#include <string>
#include <thread>
#include <vector>

namespace bench {

// Hostile clients (--hostile): each thread cycles through the attack classes of
// tests/server/test_hostile.cpp until `stop`, counting the attacks and those the server ended
// (closed or refused) within 10 s.
struct Hostile {
  std::atomic<bool> stop{false};
  std::atomic<long> attacks{0}, ended{0};
  std::vector<std::thread> threads;

  Hostile(int n, unsigned short port) {
    for (int i = 0; i < n; ++i)
      threads.emplace_back([this, port, source = "127.0.1." + std::to_string(i + 1)] {
        for (int k = 0; !stop; ++k) {
          attacks.fetch_add(1);
          if (attack(k % 6, source.c_str(), port)) ended.fetch_add(1);
        }
      });
  }
  ~Hostile() {
    stop = true;
    for (auto& t : threads) t.join();
  }

  // One attack of class `kind` (0-5) from `source`: true when the server ended it within 10 s.
  static bool attack(int kind, const char* source, unsigned short port);
};

}  // namespace bench
