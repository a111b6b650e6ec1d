#include "auth.hpp"

#include <fcntl.h>
#include <jwt.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>

#include "clock.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/server/protocol.hpp"
#include "log.hpp"
#include "routes.hpp"

namespace facecast::server {
namespace {

namespace fs = std::filesystem;

constexpr const char* kIssuer = "facecast";

[[noreturn]] void unauthorized(const std::string& why) {
  throw RequestError(Code::kUnauthorized, why);
}

// Items of a comma-separated header value, trimmed.
template <class F>
void for_each_item(std::string_view value, F f) {
  while (!value.empty()) {
    const auto comma = value.find(',');
    std::string_view item = value.substr(0, comma);
    while (!item.empty() && (item.front() == ' ' || item.front() == '\t')) item.remove_prefix(1);
    while (!item.empty() && (item.back() == ' ' || item.back() == '\t')) item.remove_suffix(1);
    if (!item.empty() && f(item)) return;
    if (comma == std::string_view::npos) break;
    value.remove_prefix(comma + 1);
  }
}

struct JwtFree {
  void operator()(jwt_t* j) const { jwt_free(j); }
};
using JwtPtr = std::unique_ptr<jwt_t, JwtFree>;

std::string grant(jwt_t* j, const char* name) {
  const char* v = jwt_get_grant(j, name);
  return v ? v : "";
}

}  // namespace

void Principal::require(std::uint32_t scope, std::string_view what) const {
  if (can(scope)) return;
  throw RequestError(Code::kForbidden, std::string(what) + " needs the scope '" +
                                           scope_names(scope) + "'" +
                                           (viewer ? " (a viewer token has only its own)" : ""));
}

Auth::Auth(const ServerOptions& o) : token_(o.token), max_ttl_(o.token_max_ttl) {
  const fs::path store = key_store_path(o);
  secret_path_ = store.parent_path() / "token_secret";
  std::error_code ec;
  const bool exists = fs::exists(store, ec);
  if (!exists && o.keys != "auto") {
    const bool named = o.keys != "required";  // "keys": "path" in the config
    throw Error("there is no key store at " + store.string() +
                " (\"keys\" in the config requires one): create a key with `facecast keys create "
                "--tenant NAME --scopes admin " +
                (named ? std::string("--config YOUR_CONFIG") : "--data " + o.data.string()) + "`");
  }
  if (exists) {
    keys_ = std::make_unique<KeyStore>(store);
    log::info("keys_loaded", {{"file", store.string()}, {"keys", keys_->list().size()}});
  }
}

Auth::~Auth() = default;

std::optional<std::string> Auth::credential(const Request& req, const Target& target) {
  const auto auth = req[http::field::authorization];
  if (auth.size() > 7 && beast::iequals(auth.substr(0, 7), "Bearer "))
    return std::string(auth.substr(7));
  std::optional<std::string> found;
  for_each_item(req[http::field::sec_websocket_protocol], [&](std::string_view item) {
    if (item.size() > kTokenSubprotocol.size() && item.starts_with(kTokenSubprotocol)) {
      found = std::string(item.substr(kTokenSubprotocol.size()));
      return true;
    }
    return false;
  });
  if (found) return found;
  return query_value(target.query, "token");
}

bool Auth::offers_first_message(const Request& req) {
  bool offered = false;
  for_each_item(req[http::field::sec_websocket_protocol],
                [&](std::string_view item) { return offered = item == kAuthFirstSubprotocol; });
  return offered;
}

Principal Auth::identify(const Request& req, const Target& target) const {
  if (!enabled()) return Principal{std::string(kDefaultTenant), kAllScopes, {}, false, {}, {}};
  const auto given = credential(req, target);
  if (!given || given->empty())
    unauthorized(
        "a key or token is required (Authorization: Bearer, the subprotocol facecast.token.<key>, "
        "or ?token=)");
  return identify(*given);
}

Principal Auth::identify(std::string_view given) const {
  if (!enabled()) return Principal{std::string(kDefaultTenant), kAllScopes, {}, false, {}, {}};
  if (!token_.empty() && constant_time_equal(given, token_))
    return Principal{std::string(kDefaultTenant), kAllScopes, {}, false, {}, {}};
  if (keys_ && given.starts_with("fc_")) {
    const auto key = keys_->verify(given);
    if (!key) unauthorized("the key is unknown or revoked");
    return Principal{key->tenant, key->scopes, key->id, false, {}, {}};
  }
  if (std::count(given.begin(), given.end(), '.') == 2) {
    if (auto p = verify_token(std::string(given))) return std::move(*p);
  }
  unauthorized("the key or token is not valid");
}

const std::string& Auth::secret() const {
  std::lock_guard lock(secret_mutex_);
  if (!secret_.empty()) return secret_;
  std::error_code ec;
  fs::create_directories(secret_path_.parent_path(), ec);
  // Made once, owner-only; another process may make it at the same time (O_EXCL decides).
  const int fd = ::open(secret_path_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd >= 0) {
    const std::string fresh = random_secret_hex(32);
    const bool ok = ::write(fd, fresh.data(), fresh.size()) == static_cast<ssize_t>(fresh.size());
    ::close(fd);
    if (!ok) {
      fs::remove(secret_path_, ec);
      throw Error(secret_path_.string() + ": cannot write the token secret", ErrorCode::kInternal);
    }
    log::info("token_secret_created", {{"file", secret_path_.string()}});
  } else if (errno != EEXIST) {
    throw Error(secret_path_.string() + ": cannot create the token secret: " + std::strerror(errno),
                ErrorCode::kInternal);
  }
  std::string text = read_file(secret_path_);
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  if (text.size() < 32)
    throw Error(secret_path_.string() + ": the token secret is too short", ErrorCode::kInternal);
  struct stat st {};
  if (::stat(secret_path_.c_str(), &st) == 0 && (st.st_mode & 077))
    log::warn("token_secret_readable",
              {{"file", secret_path_.string()}, {"hint", "chmod 600: others can sign tokens"}});
  secret_ = std::move(text);
  return secret_;
}

std::string Auth::mint(const Principal& who, std::uint32_t scope, const std::string& channel,
                       const std::string& rig, double ttl) const {
  const std::string& key = secret();
  jwt_t* raw = nullptr;
  if (jwt_new(&raw) != 0) throw Error("token: out of memory", ErrorCode::kInternal);
  const JwtPtr j(raw);
  const long now = static_cast<long>(unix_now());
  const long exp = now + static_cast<long>(std::min(ttl, max_ttl_));
  int rc = jwt_add_grant(j.get(), "iss", kIssuer);
  rc |= jwt_add_grant(j.get(), "tenant", who.tenant.c_str());
  rc |= jwt_add_grant(j.get(), "scope", scope_names(scope).c_str());
  if (!channel.empty()) rc |= jwt_add_grant(j.get(), "channel", channel.c_str());
  if (!rig.empty()) rc |= jwt_add_grant(j.get(), "rig", rig.c_str());
  if (!who.key_id.empty()) rc |= jwt_add_grant(j.get(), "key", who.key_id.c_str());
  rc |= jwt_add_grant_int(j.get(), "iat", now);
  rc |= jwt_add_grant_int(j.get(), "exp", exp);
  rc |= jwt_set_alg(j.get(), JWT_ALG_HS256, reinterpret_cast<const unsigned char*>(key.data()),
                    static_cast<int>(key.size()));
  if (rc != 0) throw Error("token: cannot build the claims", ErrorCode::kInternal);
  char* text = jwt_encode_str(j.get());
  if (!text) throw Error("token: cannot sign", ErrorCode::kInternal);
  std::string out(text);
  std::free(text);
  return out;
}

std::optional<Principal> Auth::verify_token(const std::string& token) const {
  const std::string& key = secret();
  jwt_t* raw = nullptr;
  if (jwt_decode(&raw, token.c_str(), reinterpret_cast<const unsigned char*>(key.data()),
                 static_cast<int>(key.size())) != 0 ||
      !raw) {
    if (raw) jwt_free(raw);
    return std::nullopt;
  }
  const JwtPtr j(raw);
  // Only HS256 with this server's secret: "alg": "none" and other algorithms are refused.
  if (jwt_get_alg(j.get()) != JWT_ALG_HS256 || grant(j.get(), "iss") != kIssuer)
    return std::nullopt;
  errno = 0;
  const long exp = jwt_get_grant_int(j.get(), "exp");
  if (errno != 0 || exp <= 0) return std::nullopt;
  if (static_cast<double>(exp) <= unix_now()) unauthorized("the token has expired");
  Principal p;
  p.viewer = true;
  p.tenant = grant(j.get(), "tenant");
  p.key_id = grant(j.get(), "key");
  const auto scope = scope_named(grant(j.get(), "scope"));
  if (p.tenant.empty() || !scope) return std::nullopt;
  p.scopes = *scope;
  p.channel = grant(j.get(), "channel");
  p.rig = grant(j.get(), "rig");
  if ((*scope == kScopeChannelsSubscribe && p.channel.empty()) ||
      (*scope == kScopeSpeak && p.rig.empty()) ||
      (*scope != kScopeChannelsSubscribe && *scope != kScopeSpeak))
    return std::nullopt;
  // A revoked key takes the tokens it made with it.
  if (!p.key_id.empty()) {
    const auto k = keys_ ? keys_->find(p.key_id) : std::nullopt;
    if (!k || k->revoked != 0) unauthorized("the key that made this token was revoked");
  }
  return p;
}

}  // namespace facecast::server
