#pragma once
// Job records on disk (SQLite, <data>/jobs.sqlite3) so that GET /api/jobs/{id} answers the same
// after a restart, and rendered videos are kept for a retention time. One row per job; the row is
// written when the job is queued, starts and ends (progress stays in memory).
#include <filesystem>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "facecast/server/protocol.hpp"

struct sqlite3;

namespace facecast::server {

struct JobRecord {
  std::string id, kind;
  std::string state = "queued";  // queued | running | done | failed
  std::string stage;
  double progress = 0;
  nlohmann::json result;  // null until done
  std::optional<Problem> error;
  std::map<std::string, std::filesystem::path> files;  // GET /api/jobs/{id}/{name}
  double created = 0;                                  // Unix seconds
  double finished = 0;                                 // Unix seconds, 0 while unfinished
  double seconds = 0;                                  // running time
  std::string tenant = "default";                      // whose job (and files)

  bool ended() const { return state == "done" || state == "failed"; }
  /// The GET /api/jobs/{id} body.
  nlohmann::json to_json() const;
};

class JobStore {
 public:
  /// Opens (creating) the database; throws Error naming the file when it cannot.
  explicit JobStore(const std::filesystem::path& file);
  ~JobStore();
  JobStore(const JobStore&) = delete;
  JobStore& operator=(const JobStore&) = delete;

  /// Inserts or replaces the record; throws Error on a write failure.
  void put(const JobRecord& record);
  std::optional<JobRecord> get(const std::string& id) const;
  /// Records that are still queued or running (after a restart: interrupted).
  std::vector<JobRecord> unfinished() const;
  bool remove(const std::string& id);
  /// Removes and returns the records that ended before `before` (Unix seconds).
  std::vector<JobRecord> take_ended_before(double before);
  /// The records of `tenant`'s jobs (for its disk quota).
  std::vector<JobRecord> of_tenant(const std::string& tenant) const;

 private:
  std::vector<JobRecord> query(const char* sql, const std::string& arg, double number) const;
  void exec(const char* sql) const;
  std::filesystem::path file_;
  sqlite3* db_ = nullptr;
  mutable std::mutex mutex_;
};

}  // namespace facecast::server
