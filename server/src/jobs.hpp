#pragma once
// Long work (rig builds, video renders) on its own small thread pool, never on the I/O threads.
// A job is queued -> running -> done | failed; GET /api/jobs/{id} shows its stage and progress.
// Shutdown cancels: the next progress report of a running job throws, queued jobs fail at once.
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "facecast/core/progress.hpp"
#include "metrics.hpp"

namespace facecast::server {

class JobContext {
 public:
  /// Records progress; throws Error once the server is shutting down.
  virtual void progress(std::string_view stage, double fraction) = 0;
  /// A file this job produced, served by GET /api/jobs/{id}/{name}.
  virtual void add_file(const std::string& name, const std::filesystem::path& path) = 0;
  virtual const std::string& id() const = 0;
  ProgressFn progress_fn() {
    return [this](std::string_view s, double f) { progress(s, f); };
  }

 protected:
  ~JobContext() = default;
};

class Jobs {
 public:
  /// Work returns the job's "result" JSON, or throws (the job fails with the error's message).
  using Work = std::function<nlohmann::json(JobContext&)>;

  Jobs(Metrics& metrics, int threads, int max_jobs);
  ~Jobs();
  Jobs(const Jobs&) = delete;
  Jobs& operator=(const Jobs&) = delete;

  /// Queues a job ("j1", "j2", ...); throws RequestError(kLimit, 429) when max_jobs are pending.
  std::string submit(const std::string& kind, Work work);
  /// The GET /api/jobs/{id} body, or nullopt.
  std::optional<nlohmann::json> get(const std::string& id) const;
  std::optional<std::filesystem::path> file(const std::string& id, const std::string& name) const;
  /// Cancels everything and joins the threads (idempotent).
  void shutdown();

 private:
  struct Job;
  class Context;
  void worker();

  Metrics& metrics_;
  int max_jobs_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::map<std::string, std::shared_ptr<Job>> jobs_;
  std::deque<std::shared_ptr<Job>> queue_;
  std::deque<std::string> finished_;  // oldest first, for trimming
  bool stopping_ = false;
  int next_id_ = 1;
  std::vector<std::thread> threads_;
};

}  // namespace facecast::server
