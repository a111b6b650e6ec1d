#include "jobs.hpp"

#include <pthread.h>
#include <signal.h>
#include <chrono>

#include "facecast/core/error.hpp"
#include "facecast/server/protocol.hpp"
#include "log.hpp"

namespace facecast::server {
namespace {
constexpr std::size_t kKeepFinished = 256;
}

struct Jobs::Job {
  std::string id, kind;
  Work work;
  std::string state = "queued";  // queued | running | done | failed
  std::string stage;
  double progress = 0;
  nlohmann::json result;  // null until done
  std::optional<Problem> error;
  std::map<std::string, std::filesystem::path> files;
  std::chrono::system_clock::time_point created = std::chrono::system_clock::now();
  double seconds = 0;
};

class Jobs::Context final : public JobContext {
 public:
  Context(Jobs& jobs, Job& job) : jobs_(jobs), job_(job) {}
  void progress(std::string_view stage, double fraction) override {
    std::lock_guard lock(jobs_.mutex_);
    if (jobs_.stopping_)
      throw Error("cancelled: the server is shutting down", ErrorCode::kInternal);
    job_.stage = std::string(stage);
    job_.progress = std::clamp(fraction, 0.0, 1.0);
  }
  void add_file(const std::string& name, const std::filesystem::path& path) override {
    std::lock_guard lock(jobs_.mutex_);
    job_.files[name] = path;
  }
  const std::string& id() const override { return job_.id; }

 private:
  Jobs& jobs_;
  Job& job_;
};

Jobs::Jobs(Metrics& metrics, int threads, int max_jobs) : metrics_(metrics), max_jobs_(max_jobs) {
  for (int i = 0; i < threads; ++i) threads_.emplace_back([this] { worker(); });
}

Jobs::~Jobs() {
  shutdown();
}

std::string Jobs::submit(const std::string& kind, Work work) {
  std::lock_guard lock(mutex_);
  if (stopping_) throw RequestError(Code::kUnavailable, "the server is shutting down");
  long pending = 0;
  for (const auto& [id, job] : jobs_) pending += job->state == "queued" || job->state == "running";
  if (pending >= max_jobs_) {
    throw RequestError(Code::kLimit,
                       std::to_string(pending) + " jobs are queued or running (max_jobs " +
                           std::to_string(max_jobs_) + "); try again later",
                       429);
  }
  auto job = std::make_shared<Job>();
  job->id = "j" + std::to_string(next_id_++);
  job->kind = kind;
  job->work = std::move(work);
  jobs_[job->id] = job;
  queue_.push_back(job);
  metrics_.jobs_queued.fetch_add(1);
  cv_.notify_one();
  log::info("job_queued", {{"job", job->id}, {"kind", kind}});
  return job->id;
}

std::optional<nlohmann::json> Jobs::get(const std::string& id) const {
  std::lock_guard lock(mutex_);
  const auto it = jobs_.find(id);
  if (it == jobs_.end()) return std::nullopt;
  const Job& j = *it->second;
  nlohmann::json out = {{"id", j.id},       {"kind", j.kind},         {"state", j.state},
                        {"stage", j.stage}, {"progress", j.progress}, {"result", j.result},
                        {"error", nullptr}, {"seconds", j.seconds}};
  if (j.error) out["error"] = {{"code", to_string(j.error->code)}, {"message", j.error->message}};
  return out;
}

std::optional<std::filesystem::path> Jobs::file(const std::string& id,
                                                const std::string& name) const {
  std::lock_guard lock(mutex_);
  const auto it = jobs_.find(id);
  if (it == jobs_.end() || it->second->state != "done") return std::nullopt;
  const auto f = it->second->files.find(name);
  if (f == it->second->files.end()) return std::nullopt;
  return f->second;
}

void Jobs::shutdown() {
  std::vector<std::thread> threads;
  {
    std::lock_guard lock(mutex_);
    threads.swap(threads_);
    stopping_ = true;
    for (auto& job : queue_) {
      job->state = "failed";
      job->error = Problem{Code::kUnavailable, "cancelled: the server is shutting down", 503};
      metrics_.jobs_queued.fetch_sub(1);
      metrics_.jobs_failed_total.fetch_add(1);
    }
    queue_.clear();
  }
  cv_.notify_all();
  for (auto& t : threads) t.join();
}

void Jobs::worker() {
  // Writing to a pipe whose reader died (ffmpeg) must give EPIPE, not kill the server.
  sigset_t pipe_signal;
  sigemptyset(&pipe_signal);
  sigaddset(&pipe_signal, SIGPIPE);
  pthread_sigmask(SIG_BLOCK, &pipe_signal, nullptr);
  for (;;) {
    std::shared_ptr<Job> job;
    {
      std::unique_lock lock(mutex_);
      cv_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (queue_.empty()) return;  // stopping
      job = queue_.front();
      queue_.pop_front();
      job->state = "running";
      metrics_.jobs_queued.fetch_sub(1);
      metrics_.jobs_running.fetch_add(1);
    }
    log::info("job_started", {{"job", job->id}, {"kind", job->kind}});
    const auto t0 = std::chrono::steady_clock::now();
    Context ctx(*this, *job);
    nlohmann::json result;
    std::optional<Problem> error;
    try {
      result = job->work(ctx);
    } catch (...) {
      error = describe(std::current_exception());
    }
    const double secs =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    {
      std::lock_guard lock(mutex_);
      job->seconds = secs;
      job->work = nullptr;  // release what the work captured (meshes, rigs)
      if (error) {
        job->state = "failed";
        job->error = error;
        metrics_.jobs_failed_total.fetch_add(1);
      } else {
        job->state = "done";
        job->stage = "done";
        job->progress = 1;
        job->result = std::move(result);
        metrics_.jobs_done_total.fetch_add(1);
      }
      metrics_.jobs_running.fetch_sub(1);
      finished_.push_back(job->id);
      while (finished_.size() > kKeepFinished) {
        jobs_.erase(finished_.front());
        finished_.pop_front();
      }
    }
    if (error) {
      log::warn("job_failed", {{"job", job->id},
                               {"kind", job->kind},
                               {"code", to_string(error->code)},
                               {"error", error->message},
                               {"s", secs}});
    } else {
      log::info("job_done", {{"job", job->id}, {"kind", job->kind}, {"s", secs}});
    }
  }
}

}  // namespace facecast::server
