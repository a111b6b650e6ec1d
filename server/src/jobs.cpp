#include "jobs.hpp"

#include <pthread.h>
#include <signal.h>
#include <chrono>

#include "clock.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/random.hpp"
#include "facecast/server/protocol.hpp"
#include "log.hpp"
#include "redis_bus.hpp"
#include "redis_jobs.hpp"

namespace facecast::server {
namespace {

constexpr std::size_t kKeepFinished = 256;  // ended jobs kept in memory (the store keeps all)

void remove_files(const JobRecord& r) {
  for (const auto& [name, path] : r.files) {
    std::error_code ec;
    std::filesystem::remove(path, ec);
    if (ec) log::warn("job_file_remove_failed", {{"job", r.id}, {"file", path.string()}});
  }
}

}  // namespace

class Jobs::Context final : public JobContext {
 public:
  Context(Jobs& jobs, Job& job) : jobs_(jobs), job_(job) {}
  void progress(std::string_view stage, double fraction) override {
    std::optional<JobRecord> share;
    {
      std::lock_guard lock(jobs_.mutex_);
      if (jobs_.stopping_)
        throw Error("cancelled: the server is shutting down", ErrorCode::kInternal);
      if (job_.deleted) throw Error("cancelled: the job was deleted", ErrorCode::kInternal);
      job_.record.stage = std::string(stage);
      job_.record.progress = std::clamp(fraction, 0.0, 1.0);
      // With Redis, every instance reads the record there: store progress twice a second.
      const auto now = std::chrono::steady_clock::now();
      if (jobs_.redis_ && now - job_.shared > std::chrono::milliseconds(500)) {
        job_.shared = now;
        share = job_.record;
      }
    }
    if (share && !jobs_.redis_->update(*share)) {
      std::lock_guard lock(jobs_.mutex_);
      job_.deleted = true;
      throw Error("cancelled: the job was deleted", ErrorCode::kInternal);
    }
  }
  void add_file(const std::string& name, const std::filesystem::path& path) override {
    std::lock_guard lock(jobs_.mutex_);
    job_.record.files[name] = path;
  }
  const std::string& id() const override { return job_.record.id; }

 private:
  Jobs& jobs_;
  Job& job_;
};

Jobs::Jobs(Metrics& metrics, JobsOptions options)
    : metrics_(metrics),
      options_(std::move(options)),
      budget_(static_cast<unsigned>(std::max(1, options_.threads))) {
  if (options_.redis) {
    redis_ = std::make_unique<RedisJobQueue>(options_.redis->url(), options_.redis->key(""),
                                             options_.redis->instance());
    return;  // the threads start with start(), once jobs can be made from their payloads
  }
  if (!options_.store.empty()) {
    store_ = std::make_unique<JobStore>(options_.store);
    // Jobs that were queued or running when the last process ended cannot resume: their work
    // (meshes, options) lived in that process.
    for (JobRecord r : store_->unfinished()) {
      r.state = "failed";
      r.error =
          Problem{Code::kUnavailable, "interrupted: the server stopped before it finished", 503};
      r.finished = unix_now();
      store_->put(r);
      log::warn("job_interrupted", {{"job", r.id}, {"kind", r.kind}});
    }
    expire();
  }
  for (int i = 0; i < options_.threads; ++i) threads_.emplace_back([this] { worker(); });
}

Jobs::~Jobs() {
  shutdown();
}

void Jobs::save(const JobRecord& record) const {
  if (!store_ && !redis_) return;
  try {
    if (redis_ && record.ended())
      redis_->finish(record);
    else if (redis_)
      redis_->update(record);
    else
      store_->put(record);
  } catch (const std::exception& e) {
    log::error("job_store_failed", {{"job", record.id}, {"error", e.what()}});
  }
}

long Jobs::pending_locked() const {
  long pending = inline_;
  for (const auto& [id, job] : jobs_) pending += !job->record.ended();
  return pending;
}

void Jobs::refuse_locked(long pending, const std::string& what) const {
  throw RequestError(Code::kLimit,
                     what + ": " + std::to_string(pending) +
                         " jobs (rig builds, renders, imports, audio decodes, photo landmarks) are "
                         "queued or running (max_jobs " +
                         std::to_string(options_.max_jobs) + "); try again later",
                     429);
}

std::shared_ptr<void> Jobs::hold(const std::string& what) {
  std::lock_guard lock(mutex_);
  if (stopping_) throw RequestError(Code::kUnavailable, "the server is shutting down");
  if (const long pending = pending_locked(); pending >= options_.max_jobs)
    refuse_locked(pending, what);
  ++inline_;
  return std::shared_ptr<void>(this, [this](void*) {
    std::lock_guard l(mutex_);
    --inline_;
  });
}

std::string Jobs::submit(const std::string& kind, Work work, const nlohmann::json& payload,
                         const std::string& tenant) {
  if (redis_) return redis_submit(kind, payload, tenant);
  if (store_) expire();
  std::lock_guard lock(mutex_);
  if (stopping_) throw RequestError(Code::kUnavailable, "the server is shutting down");
  if (const long pending = pending_locked(); pending >= options_.max_jobs)
    refuse_locked(pending, kind);
  auto job = std::make_shared<Job>();
  // Time-ordered and random (core/random.hpp): unique across threads, restarts and instances that
  // share a data folder, with nothing to coordinate (the Redis queue numbers its own with INCR).
  do {
    job->record.id = "j" + time_ordered_hex();
  } while (jobs_.contains(job->record.id));
  job->record.kind = kind;
  job->record.tenant = tenant;
  job->record.created = unix_now();
  job->work = std::move(work);
  save(job->record);
  jobs_[job->record.id] = job;
  queue_.push_back(job);
  metrics_.jobs_queued.fetch_add(1);
  cv_.notify_one();
  log::info("job_queued", {{"job", job->record.id}, {"kind", kind}});
  return job->record.id;
}

std::optional<JobRecord> Jobs::record(const std::string& id) const {
  if (redis_) return redis_->get(id);  // throws Error naming Redis when it is unreachable
  {
    std::lock_guard lock(mutex_);
    const auto it = jobs_.find(id);
    if (it != jobs_.end()) return it->second->record;
  }
  if (!store_) return std::nullopt;
  try {
    return store_->get(id);
  } catch (const std::exception& e) {
    log::error("job_store_failed", {{"job", id}, {"error", e.what()}});
    return std::nullopt;
  }
}

std::vector<std::filesystem::path> Jobs::tenant_files(const std::string& tenant) const {
  std::vector<JobRecord> records;
  if (redis_) {
    records = redis_->ended_of_tenant(tenant);
  } else if (store_) {
    records = store_->of_tenant(tenant);
  } else {
    std::lock_guard lock(mutex_);
    for (const auto& [id, job] : jobs_)
      if (job->record.tenant == tenant) records.push_back(job->record);
  }
  std::vector<std::filesystem::path> out;
  for (const auto& r : records)
    for (const auto& [name, path] : r.files) out.push_back(path);
  return out;
}

std::optional<nlohmann::json> Jobs::get(const std::string& id) const {
  const auto r = record(id);
  if (!r) return std::nullopt;
  return r->to_json();
}

std::optional<std::pair<std::string, std::string>> Jobs::kind_and_tenant(
    const std::string& id) const {
  const auto r = record(id);
  if (!r) return std::nullopt;
  return std::make_pair(r->kind, r->tenant);
}

std::optional<std::filesystem::path> Jobs::file(const std::string& id,
                                                const std::string& name) const {
  const auto r = record(id);
  if (!r || r->state != "done") return std::nullopt;
  const auto f = r->files.find(name);
  if (f == r->files.end()) return std::nullopt;
  return f->second;
}

bool Jobs::remove(const std::string& id) {
  std::optional<JobRecord> ended;
  bool found = false;
  {
    std::lock_guard lock(mutex_);
    const auto it = jobs_.find(id);
    if (it != jobs_.end()) {
      found = true;
      Job& job = *it->second;
      if (job.record.state == "queued") {
        std::erase(queue_, it->second);
        metrics_.jobs_queued.fetch_sub(1);
      } else if (job.record.state == "running") {
        job.deleted = true;  // the worker cancels it and removes what it wrote
      } else {
        ended = job.record;
      }
      std::erase(finished_, id);
      jobs_.erase(it);
    }
  }
  if (redis_) {
    const auto r = redis_->remove(id);
    if (r && r->ended()) ended = r;
    found = found || r;
  } else if (store_) {
    if (!ended && !found) ended = store_->get(id);
    found = store_->remove(id) || found;
  }
  if (ended) remove_files(*ended);
  if (found) log::info("job_deleted", {{"job", id}});
  return found;
}

void Jobs::expire() {
  if ((!store_ && !redis_) || options_.retention <= 0) return;
  std::vector<JobRecord> old;
  try {
    const double before = unix_now() - options_.retention;
    old = redis_ ? redis_->take_ended_before(before) : store_->take_ended_before(before);
  } catch (const std::exception& e) {
    log::error("job_store_failed", {{"error", e.what()}});
    return;
  }
  for (const auto& r : old) {
    {
      std::lock_guard lock(mutex_);
      jobs_.erase(r.id);
      std::erase(finished_, r.id);
    }
    remove_files(r);
    log::info("job_expired", {{"job", r.id}, {"kind", r.kind}});
  }
}

void Jobs::shutdown() {
  std::vector<std::thread> threads;
  {
    std::lock_guard lock(mutex_);
    threads.swap(threads_);
    stopping_ = true;
    for (auto& job : queue_) {
      job->record.state = "failed";
      job->record.error =
          Problem{Code::kUnavailable, "cancelled: the server is shutting down", 503};
      job->record.finished = unix_now();
      save(job->record);
      metrics_.jobs_queued.fetch_sub(1);
      metrics_.jobs_failed_total.fetch_add(1);
    }
    queue_.clear();
  }
  cv_.notify_all();
  for (auto& t : threads) t.join();
}

void Jobs::block_sigpipe() {
  // Writing to a pipe whose reader died (ffmpeg) must give EPIPE, not kill the server.
  sigset_t pipe_signal;
  sigemptyset(&pipe_signal);
  sigaddset(&pipe_signal, SIGPIPE);
  pthread_sigmask(SIG_BLOCK, &pipe_signal, nullptr);
}

void Jobs::worker() {
  block_sigpipe();
  for (;;) {
    std::shared_ptr<Job> job;
    {
      std::unique_lock lock(mutex_);
      cv_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (queue_.empty()) return;  // stopping
      job = queue_.front();
      queue_.pop_front();
      job->record.state = "running";
      save(job->record);
      metrics_.jobs_queued.fetch_sub(1);
      metrics_.jobs_running.fetch_add(1);
    }
    run(*job);
  }
}

void Jobs::run(Job& job) {
  const std::string& id = job.record.id;
  log::info("job_started", {{"job", id}, {"kind", job.record.kind}});
  const auto t0 = std::chrono::steady_clock::now();
  Context ctx(*this, job);
  nlohmann::json result;
  std::optional<Problem> error;
  try {
    const ThreadBudgetScope threads(budget_);  // parallel loops stay within job_workers
    result = job.work(ctx);
  } catch (...) {
    error = describe(std::current_exception());
  }
  if (error && redis_ && requeue_stopped(job)) return;
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  bool deleted;
  {
    std::lock_guard lock(mutex_);
    JobRecord& r = job.record;
    deleted = job.deleted;
    r.seconds = secs;
    r.finished = unix_now();
    job.work = nullptr;  // release what the work captured (meshes, rigs)
    if (error) {
      r.state = "failed";
      r.error = error;
      metrics_.jobs_failed_total.fetch_add(1);
    } else {
      r.state = "done";
      r.stage = "done";
      r.progress = 1;
      r.result = std::move(result);
      metrics_.jobs_done_total.fetch_add(1);
    }
    metrics_.jobs_running.fetch_sub(1);
    if (!deleted) {
      save(r);
      finished_.push_back(id);
      while (finished_.size() > kKeepFinished) {
        jobs_.erase(finished_.front());
        finished_.pop_front();
      }
    }
  }
  if (deleted) {
    remove_files(job.record);
    if (store_) store_->remove(id);  // the row it had while running
    if (redis_) redis_->forget(id);
    log::info("job_cancelled", {{"job", id}, {"reason", "deleted"}});
  } else if (error) {
    log::warn("job_failed", {{"job", id},
                             {"kind", job.record.kind},
                             {"code", to_string(error->code)},
                             {"error", error->message},
                             {"s", secs}});
  } else {
    log::info("job_done", {{"job", id}, {"kind", job.record.kind}, {"s", secs}});
  }
  if (store_) expire();
}

}  // namespace facecast::server
