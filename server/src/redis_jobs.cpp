#include "redis_jobs.hpp"

#include <chrono>
#include <thread>

#include "clock.hpp"
#include "facecast/core/error.hpp"
#include "jobs.hpp"
#include "log.hpp"
#include "redis_bus.hpp"

namespace facecast::server {

using nlohmann::json;

json record_to_storage(const JobRecord& r) {
  json j = r.to_json();
  json files = json::object();
  for (const auto& [name, path] : r.files) files[name] = path.string();
  j["files"] = files;
  j["finished"] = r.finished;
  if (r.error) j["error"]["status"] = r.error->status;
  j["tenant"] = r.tenant;
  return j;
}

JobRecord record_from_storage(const json& j) {
  JobRecord r;
  r.id = j.at("id").get<std::string>();
  r.kind = j.at("kind").get<std::string>();
  r.state = j.at("state").get<std::string>();
  r.stage = j.value("stage", "");
  r.progress = j.value("progress", 0.0);
  if (const auto it = j.find("result"); it != j.end()) r.result = *it;
  if (const auto it = j.find("error"); it != j.end() && it->is_object()) {
    const json& e = *it;
    Problem p{Code::kInternal, e.value("message", ""), e.value("status", 500)};
    const std::string code = e.value("code", "");
    for (const Code c : {Code::kInvalidInput, Code::kUnauthorized, Code::kForbidden,
                         Code::kNotFound, Code::kMethod, Code::kLimit, Code::kRateLimited,
                         Code::kUnsupported, Code::kUnavailable, Code::kInternal})
      if (to_string(c) == code) p.code = c;
    r.error = p;
  }
  if (const auto it = j.find("files"); it != j.end() && it->is_object())
    for (const auto& [name, path] : it->items()) r.files[name] = path.get<std::string>();
  r.created = j.value("created", 0.0);
  r.finished = j.value("finished", 0.0);
  r.seconds = j.value("seconds", 0.0);
  r.tenant = j.value("tenant", "default");
  return r;
}

RedisJobQueue::RedisJobQueue(RedisUrl url, std::string prefix, std::string instance)
    : client_(std::move(url)),
      prefix_(std::move(prefix)),
      instance_(std::move(instance)),
      processing_(prefix_ + "jobs:processing:" + instance_) {}

std::string RedisJobQueue::new_id() {
  return "j" + std::to_string(client_.command({"INCR", key("jobs:seq")}).integer);
}

void RedisJobQueue::submit(const JobRecord& record, const json& payload) {
  client_.pipeline({{"SET", key("job:" + record.id), record_to_storage(record).dump()},
                    {"SET", key("job:" + record.id + ":payload"), payload.dump()},
                    {"LPUSH", key("jobs:queue"), record.id}});
}

long RedisJobQueue::queued() {
  return static_cast<long>(client_.command({"LLEN", key("jobs:queue")}).integer);
}

std::optional<std::string> RedisJobQueue::take(RedisClient& client, double wait) {
  const std::string seconds = std::to_string(wait);
  const auto v =
      client.command({"BLMOVE", key("jobs:queue"), processing_, "RIGHT", "LEFT", seconds}, wait);
  if (v.nil()) return std::nullopt;
  return v.str;
}

std::optional<JobRecord> RedisJobQueue::get(const std::string& id) {
  const auto v = client_.command({"GET", key("job:" + id)});
  if (v.nil()) return std::nullopt;
  return record_from_storage(json::parse(v.str));
}

std::vector<JobRecord> RedisJobQueue::ended_of_tenant(const std::string& tenant) {
  std::vector<JobRecord> out;
  for (const auto& id : client_.command({"ZRANGE", key("jobs:ended"), "0", "-1"}).elements)
    if (auto r = get(id.str); r && r->tenant == tenant) out.push_back(std::move(*r));
  return out;
}

std::optional<json> RedisJobQueue::payload(const std::string& id) {
  const auto v = client_.command({"GET", key("job:" + id + ":payload")});
  if (v.nil()) return std::nullopt;
  return json::parse(v.str);
}

bool RedisJobQueue::update(const JobRecord& record) {
  // XX: only while the record exists; a DELETE from any instance removed it.
  return !client_.command({"SET", key("job:" + record.id), record_to_storage(record).dump(), "XX"})
              .nil();
}

void RedisJobQueue::finish(const JobRecord& r) {
  client_.pipeline({{"SET", key("job:" + r.id), record_to_storage(r).dump(), "XX"},
                    {"DEL", key("job:" + r.id + ":payload")},
                    {"ZADD", key("jobs:ended"), std::to_string(r.finished), r.id},
                    {"LREM", processing_, "0", r.id}});
}

void RedisJobQueue::requeue(const JobRecord& r) {
  JobRecord q = r;
  q.state = "queued";
  q.stage.clear();
  q.progress = 0;
  client_.pipeline({{"SET", key("job:" + r.id), record_to_storage(q).dump(), "XX"},
                    {"LREM", processing_, "0", r.id},
                    {"RPUSH", key("jobs:queue"), r.id}});
}

void RedisJobQueue::forget(const std::string& id) {
  client_.command({"LREM", processing_, "0", id});
}

std::optional<JobRecord> RedisJobQueue::remove(const std::string& id) {
  auto r = get(id);
  client_.pipeline({{"DEL", key("job:" + id), key("job:" + id + ":payload")},
                    {"LREM", key("jobs:queue"), "0", id},
                    {"ZREM", key("jobs:ended"), id}});
  return r;
}

std::vector<JobRecord> RedisJobQueue::take_ended_before(double before) {
  std::vector<JobRecord> out;
  const auto ids =
      client_.command({"ZRANGEBYSCORE", key("jobs:ended"), "-inf", std::to_string(before)});
  for (const auto& id : ids.elements) {
    // ZREM decides which instance expires it (the one whose ZREM removed it).
    if (client_.command({"ZREM", key("jobs:ended"), id.str}).integer == 0) continue;
    if (auto r = get(id.str)) out.push_back(std::move(*r));
    client_.command({"DEL", key("job:" + id.str)});
  }
  return out;
}

int RedisJobQueue::requeue_instance(const std::string& instance) {
  const std::string list = key("jobs:processing:" + instance);
  int n = 0;
  // Each back to the end of the queue the workers take from: they run next.
  while (!client_.command({"LMOVE", list, key("jobs:queue"), "RIGHT", "RIGHT"}).nil()) ++n;
  if (n > 0) log::warn("jobs_requeued", {{"instance", instance}, {"jobs", n}});
  return n;
}

// ---- Jobs with Redis ---------------------------------------------------------------------------

std::string Jobs::redis_submit(const std::string& kind, const json& payload,
                               const std::string& tenant) {
  expire();
  {
    std::lock_guard lock(mutex_);
    if (stopping_) throw RequestError(Code::kUnavailable, "the server is shutting down");
  }
  const long pending = redis_->queued();
  if (pending >= options_.max_jobs) {
    throw RequestError(Code::kLimit,
                       std::to_string(pending) + " jobs are queued (max_jobs " +
                           std::to_string(options_.max_jobs) + "); try again later",
                       429);
  }
  JobRecord r;
  r.id = redis_->new_id();
  r.kind = kind;
  r.tenant = tenant;
  r.created = unix_now();
  redis_->submit(r, payload);
  log::info("job_queued", {{"job", r.id}, {"kind", kind}, {"queue", "redis"}});
  return r.id;
}

void Jobs::start(Factory factory) {
  if (!redis_) return;
  std::lock_guard lock(mutex_);
  if (!threads_.empty() || stopping_) return;
  factory_ = std::move(factory);
  for (int i = 0; i < options_.threads; ++i) threads_.emplace_back([this] { redis_worker(); });
}

void Jobs::requeue_instance(const std::string& instance) {
  if (!redis_) return;
  try {
    redis_->requeue_instance(instance);
  } catch (const std::exception& e) {
    log::error("jobs_requeue_failed", {{"instance", instance}, {"error", e.what()}});
  }
}

// A job cancelled because this instance stops goes back to the queue for another instance.
bool Jobs::requeue_stopped(Job& job) {
  {
    std::lock_guard lock(mutex_);
    if (!stopping_ || job.deleted) return false;
    metrics_.jobs_running.fetch_sub(1);
    jobs_.erase(job.record.id);
  }
  try {
    redis_->requeue(job.record);
    log::info("job_requeued", {{"job", job.record.id}, {"reason", "shutting down"}});
  } catch (const std::exception& e) {
    log::error("job_store_failed", {{"job", job.record.id}, {"error", e.what()}});
  }
  return true;
}

// Takes one job from the shared queue and makes its work; nullptr when there was none (or it
// must not run: ended, deleted, or its payload is invalid, which fails it).
std::shared_ptr<Jobs::Job> Jobs::redis_take(RedisClient& client) {
  const auto id = redis_->take(client, 1.0);
  if (!id) return nullptr;
  auto record = redis_->get(*id);
  if (!record || record->ended()) {
    redis_->forget(*id);
    return nullptr;
  }
  auto job = std::make_shared<Job>();
  job->record = std::move(*record);
  try {
    const auto payload = redis_->payload(*id);
    if (!payload) throw Error("job " + *id + ": its payload is missing from Redis");
    job->work = factory_(job->record.kind, *payload, job->record.tenant);
  } catch (...) {
    job->record.state = "failed";
    job->record.error = describe(std::current_exception());
    job->record.finished = unix_now();
    redis_->finish(job->record);
    metrics_.jobs_failed_total.fetch_add(1);
    return nullptr;
  }
  job->record.state = "running";
  job->record.stage.clear();
  job->record.progress = 0;
  redis_->update(job->record);
  std::lock_guard lock(mutex_);
  if (stopping_) {
    redis_->requeue(job->record);
    return nullptr;
  }
  jobs_[job->record.id] = job;
  metrics_.jobs_running.fetch_add(1);
  return job;
}

void Jobs::redis_worker() {
  block_sigpipe();
  RedisClient client(options_.redis->url());  // BLMOVE blocks its connection
  bool healthy = true;
  for (;;) {
    {
      std::lock_guard lock(mutex_);
      if (stopping_) return;
    }
    std::shared_ptr<Job> job;
    try {
      job = redis_take(client);
      if (!healthy) log::info("jobs_redis_reconnected", {});
      healthy = true;
    } catch (const std::exception& e) {
      if (healthy) log::error("jobs_redis_unreachable", {{"error", e.what()}});
      healthy = false;
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
      continue;
    }
    if (job) run(*job);
  }
}

}  // namespace facecast::server
