#pragma once
// The job queue and job records in Redis (many instances): any instance's job workers take the
// queued jobs, and any instance answers GET /api/jobs/{id}. Keys under the Redis prefix:
//
//   jobs:seq                   INCR: job ids "j<N>" unique over every instance
//   job:<id>                   the record (JSON; JobRecord with its files)
//   job:<id>:payload           what the job needs to run (the request body), until it ends
//   jobs:queue                 ids waiting; LPUSH in, taken from the right
//   jobs:processing:<instance> ids an instance took (BLMOVE from the queue, atomically): when the
//                              instance's heartbeat expires a survivor moves them back
//   jobs:ended                 sorted set of ended ids by end time (retention)
//
// A job is run only from state "queued" or "running" (a requeued job): a job taken twice after a
// requeue race, or deleted meanwhile, is dropped.
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "job_store.hpp"
#include "redis_client.hpp"

namespace facecast::server {

class RedisJobQueue {
 public:
  RedisJobQueue(RedisUrl url, std::string prefix, std::string instance);

  std::string new_id();
  /// Stores the record and payload and queues the id (one pipeline).
  void submit(const JobRecord& record, const nlohmann::json& payload);
  long queued();
  /// Blocks up to `wait` seconds on `client` (one per worker thread) for a queued id, which moves
  /// into this instance's processing list.
  std::optional<std::string> take(RedisClient& client, double wait);
  std::optional<JobRecord> get(const std::string& id);
  /// The ended jobs of `tenant` (their files count against its disk quota).
  std::vector<JobRecord> ended_of_tenant(const std::string& tenant);
  std::optional<nlohmann::json> payload(const std::string& id);
  /// Progress of a running job; false when its record is gone (deleted: cancel the job).
  bool update(const JobRecord& record);
  /// An ended job: record kept (retention), payload and processing entry dropped.
  void finish(const JobRecord& record);
  /// A job this instance cannot finish (it stops): back to the front of the queue.
  void requeue(const JobRecord& record);
  /// Drops an id from this instance's processing list (a job that must not run).
  void forget(const std::string& id);
  /// Deletes the job; returns its record (nullopt when there was none).
  std::optional<JobRecord> remove(const std::string& id);
  /// Removes and returns the records that ended before `before` (Unix seconds).
  std::vector<JobRecord> take_ended_before(double before);
  /// Moves a dead instance's in-flight jobs back to the queue; returns how many.
  int requeue_instance(const std::string& instance);

 private:
  std::string key(const std::string& name) const { return prefix_ + name; }
  RedisClient client_;
  std::string prefix_, instance_, processing_;
};

/// JobRecord <-> JSON with every field (files, error status), for Redis.
nlohmann::json record_to_storage(const JobRecord& r);
JobRecord record_from_storage(const nlohmann::json& j);

}  // namespace facecast::server
