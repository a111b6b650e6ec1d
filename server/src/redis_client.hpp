#pragma once
// A small synchronous Redis client over hiredis (Debian libhiredis-dev): one connection guarded
// by a mutex, so any thread may call it. A connection that failed is dropped and made again on the
// next call (after a Redis restart the first call reconnects); errors are one-line
// facecast::Error messages naming the server ("redis 127.0.0.1:6379: Connection refused").
#include <chrono>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

struct redisContext;
struct redisReply;

namespace facecast::server {

struct RedisUrl {
  std::string host = "127.0.0.1";
  int port = 6379;
  int db = 0;
  std::string password;
  /// redis://[:password@]host[:port][/db]; throws Error naming the url when it is not one.
  static RedisUrl parse(const std::string& url);
  std::string where() const { return host + ":" + std::to_string(port); }
};

/// One reply, converted from hiredis's.
struct RedisValue {
  enum class Type { kNil, kString, kInteger, kArray, kStatus };
  Type type = Type::kNil;
  std::string str;  // kString, kStatus
  long long integer = 0;
  std::vector<RedisValue> elements;  // kArray
  bool nil() const { return type == Type::kNil; }
  static RedisValue from(const redisReply& r);
};

class RedisClient {
 public:
  /// Does not connect yet; `timeout` bounds connecting and every reply (blocking commands add
  /// their own timeout to it).
  explicit RedisClient(RedisUrl url, double timeout = 2.0);
  ~RedisClient();
  RedisClient(const RedisClient&) = delete;
  RedisClient& operator=(const RedisClient&) = delete;

  /// Runs one command; throws Error on a connection failure (the next call reconnects) or an
  /// error reply. `extra_wait`: seconds the command may block (BLMOVE) beyond the timeout.
  RedisValue command(const std::vector<std::string_view>& args, double extra_wait = 0);
  /// Sends every command in one round trip (a pipeline) and returns the replies in order.
  std::vector<RedisValue> pipeline(const std::vector<std::vector<std::string>>& commands);
  const RedisUrl& url() const { return url_; }

  /// A connected context (AUTH and SELECT done) for a subscriber thread that owns it; throws
  /// Error naming the server. Free it with redisFree.
  static redisContext* connect(const RedisUrl& url, double timeout);

 private:
  redisContext* ensure();
  void drop();
  [[noreturn]] void fail(const std::string& what);
  RedisUrl url_;
  double timeout_;
  std::mutex mutex_;
  redisContext* ctx_ = nullptr;
};

}  // namespace facecast::server
