#pragma once
// API keys and tenants (docs/security.md): `facecast keys create|list|revoke`
// writes them, `facecast serve` reads them. A key is "fc_<id>_<secret>": a 12-hex-digit id and a
// 256-bit random secret (64 hex digits); the store (SQLite, <data>/keys.sqlite3, mode 0600) keeps
// the id, the tenant, the scopes and the SHA-256 of the secret, never the secret itself.
//
//   KeyStore store(key_store_path(options));
//   const CreatedKey k = store.create("acme", parse_scopes("speak,rigs:read"));
//   std::puts(k.key.c_str());                      // shown once
//   const auto info = store.verify(k.key);         // on each request: id lookup + hash compare
//   store.revoke(k.info.id);
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "facecast/server/options.hpp"

struct sqlite3;

namespace facecast::server {

/// What a key (or a viewer token) may do; admin may do everything, and sees every tenant's rigs,
/// jobs, uploads and channels.
enum Scope : std::uint32_t {
  kScopeSpeak = 1u << 0,              // speak on its own WebSocket stream, POST /api/audio
  kScopeRender = 1u << 1,             // POST /api/render, its jobs and videos
  kScopeRigsRead = 1u << 2,           // GET /api/rigs, GLBs of its rigs
  kScopeRigsWrite = 1u << 3,          // POST/PATCH/DELETE rigs, landmarks and photo jobs
  kScopeChannelsProduce = 1u << 4,    // produce on its tenant's channels
  kScopeChannelsSubscribe = 1u << 5,  // subscribe to its tenant's channels
  kScopeMetrics = 1u << 6,            // GET /metrics
  kScopeAdmin = 1u << 7,              // everything, every tenant; `facecast keys` is local only
};
inline constexpr std::uint32_t kAllScopes = (1u << 8) - 1;

/// "speak,render,rigs:read" -> a mask; throws Error naming an unknown scope (or an empty list).
std::uint32_t parse_scopes(std::string_view list);
/// The mask as "speak,render,..." (in the order above).
std::string scope_names(std::uint32_t scopes);
/// One scope's name ("rigs:write"); nullopt when `name` is none.
std::optional<Scope> scope_named(std::string_view name);

/// A tenant name: 1-64 of A-Z a-z 0-9 _ - . (throws Error naming `field` otherwise).
void check_tenant_name(std::string_view tenant, std::string_view field = "tenant");

/// Where `options` keep the key store: "keys" when it is a path, else <data>/keys.sqlite3.
std::filesystem::path key_store_path(const ServerOptions& options);

struct KeyInfo {
  std::string id;  // 12 hex digits
  std::string tenant;
  std::uint32_t scopes = 0;
  double created = 0;    // Unix seconds
  double last_used = 0;  // Unix seconds, 0: never (updated at most once a minute)
  double revoked = 0;    // Unix seconds, 0: active
};

struct CreatedKey {
  KeyInfo info;
  std::string key;  // "fc_<id>_<secret>": shown once, stored only as a hash
};

/// SHA-256 of `bytes` as 64 lowercase hex digits (OpenSSL).
std::string sha256_hex(std::string_view bytes);
/// Whether two secrets (or their hashes) are equal, in a time that does not depend on where they
/// differ (OpenSSL CRYPTO_memcmp); unequal lengths are unequal at once.
bool constant_time_equal(std::string_view a, std::string_view b);
/// `n` bytes from the system's CSPRNG (OpenSSL RAND_bytes) as 2n hex digits.
std::string random_secret_hex(int n);

class KeyStore {
 public:
  /// Opens the store; `create` makes the file (mode 0600) and its folder when missing, otherwise a
  /// missing file throws Error(kNotFound) naming it.
  explicit KeyStore(const std::filesystem::path& file, bool create = false);
  ~KeyStore();
  KeyStore(const KeyStore&) = delete;
  KeyStore& operator=(const KeyStore&) = delete;

  const std::filesystem::path& file() const { return file_; }

  CreatedKey create(const std::string& tenant, std::uint32_t scopes);
  /// Every key, revoked ones too, oldest first.
  std::vector<KeyInfo> list() const;
  /// False when there is no active key `id`.
  bool revoke(const std::string& id);
  /// The active key that `key` is ("fc_<id>_<secret>"), or nullopt: unknown id, wrong secret,
  /// revoked. Compares hashes in constant time; records the use (at most once a minute).
  std::optional<KeyInfo> verify(std::string_view key);
  /// The key `id` (revoked ones too), or nullopt.
  std::optional<KeyInfo> find(const std::string& id) const;

 private:
  void exec(const char* sql) const;
  std::filesystem::path file_;
  sqlite3* db_ = nullptr;
  mutable std::mutex mutex_;
};

}  // namespace facecast::server
