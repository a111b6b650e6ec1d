#include "redis_client.hpp"

#include <hiredis/hiredis.h>
#include <sys/time.h>

#include <cmath>
#include <regex>

#include "facecast/core/error.hpp"
#include "facecast/core/subprocess.hpp"

namespace facecast::server {
namespace {

timeval to_timeval(double seconds) {
  timeval tv{};
  tv.tv_sec = static_cast<time_t>(seconds);
  tv.tv_usec = static_cast<suseconds_t>(std::fmod(seconds, 1.0) * 1e6);
  return tv;
}

std::string error_text(redisContext* c, const char* fallback) {
  if (c && c->err) return c->errstr[0] ? std::string(c->errstr) : std::string(fallback);
  return fallback;
}

// Runs a command on a context the caller owns; nullptr and c->err set on an I/O failure.
redisReply* run(redisContext* c, const std::vector<std::string_view>& args) {
  std::vector<const char*> argv;
  std::vector<std::size_t> lens;
  for (const auto& a : args) {
    argv.push_back(a.data());
    lens.push_back(a.size());
  }
  return static_cast<redisReply*>(
      redisCommandArgv(c, static_cast<int>(argv.size()), argv.data(), lens.data()));
}

}  // namespace

RedisUrl RedisUrl::parse(const std::string& url) {
  static const std::regex re(
      R"(redis://(?::([^@]*)@)?([^:/@]+)(?::([0-9]{1,5}))?(?:/([0-9]{1,2}))?/?)");
  std::smatch m;
  if (!std::regex_match(url, m, re))
    throw Error("redis.url: '" + url + "' is not redis://[:password@]host[:port][/db]");
  RedisUrl u;
  u.password = m[1];
  u.host = m[2];
  if (m[3].matched) u.port = std::stoi(m[3]);
  if (m[4].matched) u.db = std::stoi(m[4]);
  if (u.port < 1 || u.port > 65535)
    throw Error("redis.url: port " + std::string(m[3]) + " is out of range");
  return u;
}

RedisValue RedisValue::from(const redisReply& r) {
  RedisValue v;
  switch (r.type) {
    case REDIS_REPLY_STRING:
      v.type = Type::kString;
      v.str.assign(r.str, r.len);
      break;
    case REDIS_REPLY_STATUS:
    case REDIS_REPLY_ERROR:
      v.type = Type::kStatus;
      v.str.assign(r.str, r.len);
      break;
    case REDIS_REPLY_INTEGER:
      v.type = Type::kInteger;
      v.integer = r.integer;
      break;
    case REDIS_REPLY_ARRAY:
      v.type = Type::kArray;
      for (std::size_t i = 0; i < r.elements; ++i) v.elements.push_back(from(*r.element[i]));
      break;
    default:
      break;  // nil
  }
  return v;
}

RedisClient::RedisClient(RedisUrl url, double timeout) : url_(std::move(url)), timeout_(timeout) {}

RedisClient::~RedisClient() {
  drop();
}

redisContext* RedisClient::connect(const RedisUrl& url, double timeout) {
  redisContext* c = redisConnectWithTimeout(url.host.c_str(), url.port, to_timeval(timeout));
  if (!c || c->err) {
    const std::string why = error_text(c, "cannot allocate a connection");
    if (c) redisFree(c);
    throw Error("redis " + url.where() + ": " + why, ErrorCode::kInternal);
  }
  set_cloexec(c->fd);  // hiredis connects without SOCK_CLOEXEC: no child may hold Redis
  redisSetTimeout(c, to_timeval(timeout));
  auto check = [&](redisReply* r, const char* what) {
    const bool bad = !r || r->type == REDIS_REPLY_ERROR;
    const std::string why = r ? std::string(r->str ? r->str : "") : error_text(c, "no reply");
    if (r) freeReplyObject(r);
    if (bad) {
      redisFree(c);
      throw Error("redis " + url.where() + ": " + what + ": " + why, ErrorCode::kInternal);
    }
  };
  if (!url.password.empty()) check(run(c, {"AUTH", url.password}), "AUTH");
  if (url.db != 0) {
    const std::string db = std::to_string(url.db);
    check(run(c, {"SELECT", db}), "SELECT");
  }
  return c;
}

redisContext* RedisClient::ensure() {
  if (!ctx_) ctx_ = connect(url_, timeout_);
  return ctx_;
}

void RedisClient::drop() {
  if (ctx_) redisFree(ctx_);
  ctx_ = nullptr;
}

void RedisClient::fail(const std::string& what) {
  const std::string why = error_text(ctx_, "connection lost");
  drop();
  throw Error("redis " + url_.where() + ": " + what + ": " + why, ErrorCode::kInternal);
}

RedisValue RedisClient::command(const std::vector<std::string_view>& args, double extra_wait) {
  std::lock_guard lock(mutex_);
  // A connection Redis closed (restart, idle timeout) fails its first command: retry once on a
  // new one. Commands here are idempotent or guarded by their callers (a job runs only from
  // "queued"), so a repeat is harmless.
  for (int attempt = 0;; ++attempt) {
    redisContext* c = ensure();
    if (extra_wait > 0) redisSetTimeout(c, to_timeval(timeout_ + extra_wait));
    redisReply* r = run(c, args);
    if (extra_wait > 0 && r) redisSetTimeout(c, to_timeval(timeout_));
    if (!r) {
      if (attempt == 0) {
        drop();
        continue;
      }
      fail(std::string(args.front()));
    }
    RedisValue v = RedisValue::from(*r);
    const bool error = r->type == REDIS_REPLY_ERROR;
    freeReplyObject(r);
    if (error)
      throw Error("redis " + url_.where() + ": " + std::string(args.front()) + ": " + v.str,
                  ErrorCode::kInternal);
    return v;
  }
}

std::vector<RedisValue> RedisClient::pipeline(
    const std::vector<std::vector<std::string>>& commands) {
  std::lock_guard lock(mutex_);
  redisContext* c = ensure();
  for (const auto& cmd : commands) {
    std::vector<const char*> argv;
    std::vector<std::size_t> lens;
    for (const auto& a : cmd) {
      argv.push_back(a.data());
      lens.push_back(a.size());
    }
    if (redisAppendCommandArgv(c, static_cast<int>(argv.size()), argv.data(), lens.data()) !=
        REDIS_OK)
      fail("pipeline");
  }
  std::vector<RedisValue> out;
  for (std::size_t i = 0; i < commands.size(); ++i) {
    void* raw = nullptr;
    if (redisGetReply(c, &raw) != REDIS_OK || !raw) fail(commands[i].front());
    auto* r = static_cast<redisReply*>(raw);
    out.push_back(RedisValue::from(*r));
    freeReplyObject(r);
  }
  return out;
}

}  // namespace facecast::server
