#include "job_store.hpp"

#include <sqlite3.h>

#include "facecast/core/error.hpp"
#include "sqlite_statement.hpp"

namespace facecast::server {
namespace {

using nlohmann::json;

constexpr const char* kJobColumns =
    "id, kind, state, stage, progress, result, error_code, error_message, error_status, files, "
    "created, finished, seconds, tenant";

JobRecord read_job(const Statement& s) {
  JobRecord r;
  r.id = s.column_text(0);
  r.kind = s.column_text(1);
  r.state = s.column_text(2);
  r.stage = s.column_text(3);
  r.progress = sqlite3_column_double(s.get(), 4);
  const std::string result = s.column_text(5);
  r.result = result.empty() ? json() : json::parse(result, nullptr, false);
  const std::string code = s.column_text(6);
  if (!code.empty()) {
    Problem p{Code::kInternal, s.column_text(7), sqlite3_column_int(s.get(), 8)};
    for (const Code c : {Code::kInvalidInput, Code::kUnauthorized, Code::kForbidden,
                         Code::kNotFound, Code::kMethod, Code::kLimit, Code::kRateLimited,
                         Code::kUnsupported, Code::kUnavailable, Code::kInternal}) {
      if (to_string(c) == code) p.code = c;
    }
    r.error = p;
  }
  const json files = json::parse(s.column_text(9), nullptr, false);
  if (files.is_object()) {
    for (const auto& [name, path] : files.items())
      if (path.is_string()) r.files[name] = path.get<std::string>();
  }
  r.created = sqlite3_column_double(s.get(), 10);
  r.finished = sqlite3_column_double(s.get(), 11);
  r.seconds = sqlite3_column_double(s.get(), 12);
  r.tenant = s.column_text(13);
  return r;
}

}  // namespace

json JobRecord::to_json() const {
  json out = {{"id", id},         {"kind", kind},         {"state", state},
              {"stage", stage},   {"progress", progress}, {"result", result},
              {"error", nullptr}, {"seconds", seconds},   {"created", created}};
  if (error) out["error"] = {{"code", to_string(error->code)}, {"message", error->message}};
  return out;
}

JobStore::JobStore(const std::filesystem::path& file) : file_(file) {
  std::error_code ec;
  std::filesystem::create_directories(file.parent_path(), ec);
  if (sqlite3_open_v2(file.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr) !=
      SQLITE_OK) {
    const std::string why = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw Error(file.string() + ": cannot open the job database: " + why, ErrorCode::kInternal);
  }
  sqlite3_busy_timeout(db_, 5000);
  try {
    // WAL: readers do not wait for the writer; a crash loses at most the last transaction.
    exec("PRAGMA journal_mode=WAL");
    exec("PRAGMA synchronous=NORMAL");
    exec(
        "CREATE TABLE IF NOT EXISTS jobs (id TEXT PRIMARY KEY, kind TEXT NOT NULL, state TEXT NOT "
        "NULL, stage TEXT NOT NULL, progress REAL NOT NULL, result TEXT NOT NULL, error_code TEXT "
        "NOT NULL, error_message TEXT NOT NULL, error_status INTEGER NOT NULL, files TEXT NOT "
        "NULL, created REAL NOT NULL, finished REAL NOT NULL, seconds REAL NOT NULL, tenant TEXT "
        "NOT NULL DEFAULT 'default')");
    // Stores made before tenants: their jobs are the default tenant's.
    bool has_tenant = false;
    {
      Statement s(db_, "PRAGMA table_info(jobs)", file_);
      while (sqlite3_step(s.get()) == SQLITE_ROW) has_tenant |= s.column_text(1) == "tenant";
    }
    if (!has_tenant) exec("ALTER TABLE jobs ADD COLUMN tenant TEXT NOT NULL DEFAULT 'default'");
  } catch (...) {
    sqlite3_close(db_);
    throw;
  }
}

JobStore::~JobStore() {
  sqlite3_close(db_);
}

void JobStore::exec(const char* sql) const {
  char* message = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &message) != SQLITE_OK) {
    const std::string why = message ? message : sqlite3_errmsg(db_);
    sqlite3_free(message);
    throw Error(file_.string() + ": " + why, ErrorCode::kInternal);
  }
}

void JobStore::put(const JobRecord& r) {
  json files = json::object();
  for (const auto& [name, path] : r.files) files[name] = path.string();
  std::lock_guard lock(mutex_);
  Statement s(db_,
              "INSERT OR REPLACE INTO jobs (id, kind, state, stage, progress, result, error_code, "
              "error_message, error_status, files, created, finished, seconds, tenant) VALUES "
              "(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14)",
              file_);
  s.text(1, r.id);
  s.text(2, r.kind);
  s.text(3, r.state);
  s.text(4, r.stage);
  s.real(5, r.progress);
  s.text(6,
         r.result.is_null() ? "" : r.result.dump(-1, ' ', false, json::error_handler_t::replace));
  s.text(7, r.error ? std::string(to_string(r.error->code)) : "");
  s.text(8, r.error ? r.error->message : "");
  sqlite3_bind_int(s.get(), 9, r.error ? r.error->status : 0);
  s.text(10, files.dump());
  s.real(11, r.created);
  s.real(12, r.finished);
  s.real(13, r.seconds);
  s.text(14, r.tenant);
  if (sqlite3_step(s.get()) != SQLITE_DONE)
    throw Error(file_.string() + ": cannot store job " + r.id + ": " + sqlite3_errmsg(db_),
                ErrorCode::kInternal);
}

std::vector<JobRecord> JobStore::query(const char* where, const std::string& arg,
                                       double number) const {
  const std::string sql = std::string("SELECT ") + kJobColumns + " FROM jobs WHERE " + where;
  std::lock_guard lock(mutex_);
  Statement s(db_, sql.c_str(), file_);
  if (sqlite3_bind_parameter_count(s.get()) >= 1) {
    if (arg.empty())
      s.real(1, number);
    else
      s.text(1, arg);
  }
  std::vector<JobRecord> out;
  int rc;
  while ((rc = sqlite3_step(s.get())) == SQLITE_ROW) out.push_back(read_job(s));
  if (rc != SQLITE_DONE)
    throw Error(file_.string() + ": " + sqlite3_errmsg(db_), ErrorCode::kInternal);
  return out;
}

std::optional<JobRecord> JobStore::get(const std::string& id) const {
  auto rows = query("id = ?1", id, 0);
  if (rows.empty()) return std::nullopt;
  return std::move(rows.front());
}

std::vector<JobRecord> JobStore::unfinished() const {
  return query("state IN ('queued', 'running') ORDER BY created", {}, 0);
}

bool JobStore::remove(const std::string& id) {
  std::lock_guard lock(mutex_);
  Statement s(db_, "DELETE FROM jobs WHERE id = ?1", file_);
  s.text(1, id);
  if (sqlite3_step(s.get()) != SQLITE_DONE)
    throw Error(file_.string() + ": " + sqlite3_errmsg(db_), ErrorCode::kInternal);
  return sqlite3_changes(db_) > 0;
}

std::vector<JobRecord> JobStore::of_tenant(const std::string& tenant) const {
  return query("tenant = ?1", tenant, 0);
}

std::vector<JobRecord> JobStore::take_ended_before(double before) {
  auto rows = query("finished > 0 AND finished < ?1", {}, before);
  for (const auto& r : rows) remove(r.id);
  return rows;
}

}  // namespace facecast::server
