#include "facecast/server/keys.hpp"

#include <fcntl.h>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/rand.h>
#include <sqlite3.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <regex>

#include "clock.hpp"
#include "facecast/core/error.hpp"
#include "sqlite_statement.hpp"

namespace facecast::server {
namespace {

namespace fs = std::filesystem;

constexpr std::pair<std::string_view, Scope> kScopes[] = {
    {"speak", kScopeSpeak},
    {"render", kScopeRender},
    {"rigs:read", kScopeRigsRead},
    {"rigs:write", kScopeRigsWrite},
    {"channels:produce", kScopeChannelsProduce},
    {"channels:subscribe", kScopeChannelsSubscribe},
    {"metrics", kScopeMetrics},
    {"admin", kScopeAdmin},
};

constexpr std::string_view kKeyPrefix = "fc_";
constexpr std::size_t kIdLength = 12;      // hex digits
constexpr std::size_t kSecretLength = 64;  // hex digits: 256 bits

std::string to_hex(const unsigned char* bytes, std::size_t n) {
  static const char* hex = "0123456789abcdef";
  std::string out;
  out.reserve(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    out += hex[bytes[i] >> 4];
    out += hex[bytes[i] & 15];
  }
  return out;
}

bool is_hex(std::string_view s) {
  for (const char c : s)
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  return true;
}

constexpr const char* kKeyColumns = "id, tenant, scopes, created, last_used, revoked";

KeyInfo read_key(const Statement& s) {
  KeyInfo k;
  k.id = s.column_text(0);
  k.tenant = s.column_text(1);
  k.scopes = static_cast<std::uint32_t>(sqlite3_column_int64(s.get(), 2));
  k.created = sqlite3_column_double(s.get(), 3);
  k.last_used = sqlite3_column_double(s.get(), 4);
  k.revoked = sqlite3_column_double(s.get(), 5);
  return k;
}

}  // namespace

std::uint32_t parse_scopes(std::string_view list) {
  std::uint32_t out = 0;
  while (!list.empty()) {
    const auto comma = list.find(',');
    std::string_view item = list.substr(0, comma);
    while (!item.empty() && item.front() == ' ') item.remove_prefix(1);
    while (!item.empty() && item.back() == ' ') item.remove_suffix(1);
    if (!item.empty()) {
      const auto s = scope_named(item);
      if (!s) {
        std::string known;
        for (const auto& [name, v] : kScopes)
          known += (known.empty() ? "" : ", ") + std::string(name);
        throw Error("scopes: '" + std::string(item) + "' is not one of " + known);
      }
      out |= *s;
    }
    if (comma == std::string_view::npos) break;
    list.remove_prefix(comma + 1);
  }
  if (!out) throw Error("scopes: empty (e.g. --scopes speak,rigs:read)");
  return out;
}

std::string scope_names(std::uint32_t scopes) {
  std::string out;
  for (const auto& [name, v] : kScopes)
    if (scopes & v) out += (out.empty() ? "" : ",") + std::string(name);
  return out;
}

std::optional<Scope> scope_named(std::string_view name) {
  for (const auto& [n, v] : kScopes)
    if (n == name) return v;
  return std::nullopt;
}

void check_tenant_name(std::string_view tenant, std::string_view field) {
  static const std::regex re("[A-Za-z0-9_.-]{1,64}");
  if (!std::regex_match(tenant.begin(), tenant.end(), re))
    throw Error(std::string(field) + ": '" + std::string(tenant) +
                "' is not 1 to 64 of A-Z a-z 0-9 _ - .");
}

fs::path key_store_path(const ServerOptions& o) {
  if (o.keys != "auto" && o.keys != "required") return o.keys;
  return o.data / "keys.sqlite3";
}

bool constant_time_equal(std::string_view a, std::string_view b) {
  return a.size() == b.size() && CRYPTO_memcmp(a.data(), b.data(), a.size()) == 0;
}

std::string sha256_hex(std::string_view bytes) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), digest, &n, EVP_sha256(), nullptr) != 1)
    throw Error("sha256: OpenSSL failed", ErrorCode::kInternal);
  return to_hex(digest, n);
}

std::string random_secret_hex(int n) {
  std::vector<unsigned char> bytes(static_cast<std::size_t>(n));
  if (RAND_bytes(bytes.data(), n) != 1)
    throw Error("random: OpenSSL RAND_bytes failed", ErrorCode::kInternal);
  return to_hex(bytes.data(), bytes.size());
}

KeyStore::KeyStore(const fs::path& file, bool create) : file_(file) {
  std::error_code ec;
  if (!fs::exists(file, ec)) {
    if (!create)
      throw Error(file.string() + ": no key store (facecast keys create makes one)",
                  ErrorCode::kNotFound);
    if (file.has_parent_path()) fs::create_directories(file.parent_path(), ec);
    // Created here, owner-only, before SQLite opens it (its -wal and -shm files copy the mode).
    const int fd = ::open(file.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    if (fd < 0 && errno != EEXIST)
      throw Error(file.string() + ": cannot create the key store: " + std::strerror(errno),
                  ErrorCode::kInternal);
    if (fd >= 0) ::close(fd);
  }
  if (sqlite3_open_v2(file.c_str(), &db_, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK) {
    const std::string why = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw Error(file.string() + ": cannot open the key store: " + why, ErrorCode::kInternal);
  }
  sqlite3_busy_timeout(db_, 5000);
  try {
    exec("PRAGMA journal_mode=WAL");
    exec(
        "CREATE TABLE IF NOT EXISTS api_keys (id TEXT PRIMARY KEY, tenant TEXT NOT NULL, scopes "
        "INTEGER NOT NULL, secret_sha256 TEXT NOT NULL, created REAL NOT NULL, last_used REAL NOT "
        "NULL, revoked REAL NOT NULL)");
  } catch (...) {
    sqlite3_close(db_);
    throw;
  }
}

KeyStore::~KeyStore() {
  sqlite3_close(db_);
}

void KeyStore::exec(const char* sql) const {
  char* message = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &message) != SQLITE_OK) {
    const std::string why = message ? message : sqlite3_errmsg(db_);
    sqlite3_free(message);
    throw Error(file_.string() + ": " + why, ErrorCode::kInternal);
  }
}

CreatedKey KeyStore::create(const std::string& tenant, std::uint32_t scopes) {
  check_tenant_name(tenant);
  if (!scopes || (scopes & ~kAllScopes)) throw Error("scopes: none or unknown");
  CreatedKey out;
  out.info.id = random_secret_hex(kIdLength / 2);
  out.info.tenant = tenant;
  out.info.scopes = scopes;
  out.info.created = unix_now();
  const std::string secret = random_secret_hex(kSecretLength / 2);
  out.key = std::string(kKeyPrefix) + out.info.id + "_" + secret;
  std::lock_guard lock(mutex_);
  Statement s(db_,
              "INSERT INTO api_keys (id, tenant, scopes, secret_sha256, created, last_used, "
              "revoked) VALUES (?1, ?2, ?3, ?4, ?5, 0, 0)",
              file_);
  s.text(1, out.info.id);
  s.text(2, tenant);
  sqlite3_bind_int64(s.get(), 3, scopes);
  s.text(4, sha256_hex(secret));
  s.real(5, out.info.created);
  if (sqlite3_step(s.get()) != SQLITE_DONE)
    throw Error(file_.string() + ": cannot store the key: " + sqlite3_errmsg(db_),
                ErrorCode::kInternal);
  return out;
}

std::vector<KeyInfo> KeyStore::list() const {
  std::lock_guard lock(mutex_);
  Statement s(db_,
              (std::string("SELECT ") + kKeyColumns + " FROM api_keys ORDER BY created").c_str(),
              file_);
  std::vector<KeyInfo> out;
  int rc;
  while ((rc = sqlite3_step(s.get())) == SQLITE_ROW) out.push_back(read_key(s));
  if (rc != SQLITE_DONE)
    throw Error(file_.string() + ": " + sqlite3_errmsg(db_), ErrorCode::kInternal);
  return out;
}

bool KeyStore::revoke(const std::string& id) {
  std::lock_guard lock(mutex_);
  Statement s(db_, "UPDATE api_keys SET revoked = ?2 WHERE id = ?1 AND revoked = 0", file_);
  s.text(1, id);
  s.real(2, unix_now());
  if (sqlite3_step(s.get()) != SQLITE_DONE)
    throw Error(file_.string() + ": " + sqlite3_errmsg(db_), ErrorCode::kInternal);
  return sqlite3_changes(db_) > 0;
}

std::optional<KeyInfo> KeyStore::find(const std::string& id) const {
  std::lock_guard lock(mutex_);
  Statement s(db_, (std::string("SELECT ") + kKeyColumns + " FROM api_keys WHERE id = ?1").c_str(),
              file_);
  s.text(1, id);
  const int rc = sqlite3_step(s.get());
  if (rc == SQLITE_ROW) return read_key(s);
  if (rc != SQLITE_DONE)
    throw Error(file_.string() + ": " + sqlite3_errmsg(db_), ErrorCode::kInternal);
  return std::nullopt;
}

std::optional<KeyInfo> KeyStore::verify(std::string_view key) {
  if (key.size() != kKeyPrefix.size() + kIdLength + 1 + kSecretLength ||
      !key.starts_with(kKeyPrefix) || key[kKeyPrefix.size() + kIdLength] != '_')
    return std::nullopt;
  const std::string id(key.substr(kKeyPrefix.size(), kIdLength));
  const std::string_view secret = key.substr(kKeyPrefix.size() + kIdLength + 1);
  if (!is_hex(id) || !is_hex(secret)) return std::nullopt;
  const std::string hash = sha256_hex(secret);
  std::lock_guard lock(mutex_);
  std::optional<KeyInfo> info;
  std::string stored;
  {
    Statement s(
        db_,
        (std::string("SELECT ") + kKeyColumns + ", secret_sha256 FROM api_keys WHERE id = ?1")
            .c_str(),
        file_);
    s.text(1, id);
    const int rc = sqlite3_step(s.get());
    if (rc == SQLITE_ROW) {
      info = read_key(s);
      stored = s.column_text(6);
    } else if (rc != SQLITE_DONE) {
      throw Error(file_.string() + ": " + sqlite3_errmsg(db_), ErrorCode::kInternal);
    }
  }
  // The hash is compared even for an unknown id, so timing does not tell ids apart.
  const bool match = constant_time_equal(hash, info ? stored : std::string(hash.size(), 'x'));
  if (!info || !match || info->revoked != 0) return std::nullopt;
  const double now = unix_now();
  if (now - info->last_used > 60) {
    Statement s(db_, "UPDATE api_keys SET last_used = ?2 WHERE id = ?1", file_);
    s.text(1, id);
    s.real(2, now);
    (void)sqlite3_step(s.get());  // a busy store only delays the record
    info->last_used = now;
  }
  return info;
}

}  // namespace facecast::server
