#pragma once
// Long work (rig builds, video renders) on its own small thread pool, never on the I/O threads.
// A job is queued -> running -> done | failed; GET /api/jobs/{id} shows its stage and progress.
// Records are kept in a JobStore (SQLite) when one is given: a restart keeps finished jobs and
// marks the ones it interrupted as failed; ended jobs and their files (videos) are removed after
// the retention time. Shutdown cancels: the next progress report of a running job throws, queued
// jobs fail at once. All jobs share a ThreadBudget of `threads` threads: a running job holds one,
// and the parallel loops of its work (rig builds) borrow from the rest.
#include <chrono>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "facecast/core/progress.hpp"
#include "facecast/core/threads.hpp"
#include "job_store.hpp"
#include "metrics.hpp"
#include "redis_client.hpp"

namespace facecast::server {

class JobContext {
 public:
  /// Records progress; throws Error once the server is shutting down or the job was deleted.
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

class RedisBus;
class RedisJobQueue;

struct JobsOptions {
  int threads = 1;                   // job_workers
  int max_jobs = 8;                  // queued + running
  std::filesystem::path store;       // SQLite file; empty: records only in memory
  double retention = 7 * 24 * 3600;  // seconds an ended job and its files are kept (0: forever)
  // With Redis (many instances): the queue and the records live there (redis_jobs.hpp), `store`
  // is not used, and the threads start with start().
  RedisBus* redis = nullptr;
};

class Jobs {
 public:
  /// Work returns the job's "result" JSON, or throws (the job fails with the error's message).
  using Work = std::function<nlohmann::json(JobContext&)>;

  /// Rebuilds a job's work from what submit() was given as `payload` (with Redis, on whichever
  /// instance takes the job); throws Error when the payload is not valid.
  using Factory = std::function<Work(const std::string& kind, const nlohmann::json& payload,
                                     const std::string& tenant)>;

  /// Opens the store (throws Error naming it when it cannot) and starts the threads (with Redis:
  /// start() does).
  Jobs(Metrics& metrics, JobsOptions options);
  ~Jobs();
  Jobs(const Jobs&) = delete;
  Jobs& operator=(const Jobs&) = delete;

  /// Queues a job ("j" + 20 hex digits: 12 of Unix milliseconds, 8 random; with Redis "j" + a
  /// number); throws RequestError(kLimit, 429) when max_jobs are pending.
  /// With Redis the job is queued as `payload` (the factory makes its work where it runs).
  /// `tenant` owns the job and its files (GET/DELETE answer 404 to other tenants).
  std::string submit(const std::string& kind, Work work, const nlohmann::json& payload = {},
                     const std::string& tenant = "default");
  /// Work done within a request that costs like a job (a rig import, an audio decode, photo
  /// landmarks) counts against max_jobs while the returned handle lives; throws
  /// RequestError(kLimit, 429) naming `what` when max_jobs are pending.
  std::shared_ptr<void> hold(const std::string& what);
  /// With Redis: starts the threads, which take jobs from the shared queue.
  void start(Factory factory);
  /// With Redis: moves a dead instance's in-flight jobs back to the queue.
  void requeue_instance(const std::string& instance);
  /// The GET /api/jobs/{id} body, or nullopt.
  std::optional<nlohmann::json> get(const std::string& id) const;
  /// Kind and tenant of job `id`, or nullopt when there is none.
  std::optional<std::pair<std::string, std::string>> kind_and_tenant(const std::string& id) const;
  std::optional<std::filesystem::path> file(const std::string& id, const std::string& name) const;
  /// The files (videos) of `tenant`'s jobs, for its disk quota.
  std::vector<std::filesystem::path> tenant_files(const std::string& tenant) const;
  /// DELETE /api/jobs/{id}: forgets the job and removes its files; a queued job never runs, a
  /// running one is cancelled at its next progress report. False when there is no such job.
  bool remove(const std::string& id);
  /// Removes the jobs that ended more than the retention time ago, with their files.
  void expire();
  /// Cancels everything and joins the threads (idempotent).
  void shutdown();

 private:
  struct Job {
    JobRecord record;
    Work work;
    bool deleted = false;                          // DELETE while running: cancelled, nothing kept
    std::chrono::steady_clock::time_point shared;  // with Redis: when progress was last stored
  };
  class Context;
  static void block_sigpipe();  // the job threads (ffmpeg pipes: EPIPE, not a signal)
  void worker();
  void run(Job& job);
  // With Redis (defined in redis_jobs.cpp).
  void redis_worker();
  std::shared_ptr<Job> redis_take(RedisClient& client);
  std::string redis_submit(const std::string& kind, const nlohmann::json& payload,
                           const std::string& tenant);
  bool requeue_stopped(Job& job);
  void save(const JobRecord& record) const;  // to the store, if any; logs a failure
  std::optional<JobRecord> record(const std::string& id) const;

  long pending_locked() const;  // jobs not ended + work held inline; mutex_ held
  [[noreturn]] void refuse_locked(long pending, const std::string& what) const;

  Metrics& metrics_;
  long inline_ = 0;  // hold()s alive
  JobsOptions options_;
  std::unique_ptr<JobStore> store_;
  std::unique_ptr<RedisJobQueue> redis_;
  Factory factory_;
  ThreadBudget budget_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::map<std::string, std::shared_ptr<Job>> jobs_;
  std::deque<std::shared_ptr<Job>> queue_;
  std::deque<std::string> finished_;  // oldest first, for trimming the memory
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace facecast::server
