#pragma once
// Who is calling and what they may do (docs/security.md): the one place where
// credentials are checked. Routes, the WebSocket upgrade and WebSocket messages ask it:
//
//   const Principal who = state.auth.identify(req, target);  // 401: none, unknown, expired
//   who.require(kScopeRender, "POST /api/render");            // 403: not this key's scope
//   if (!who.owns(job_tenant)) -> 404                         // another tenant's things
//
// Credentials: an API key (KeyStore), the old single `token` (an admin key of tenant "default"),
// or a viewer token (JWT HS256 from POST /api/tokens: one channel to subscribe to, or one rig to
// speak with). They travel as "Authorization: Bearer C", in the WebSocket subprotocol list
// ("facecast.v1, facecast.token.C"), as "?token=C" (proxies log it), or, for a WebSocket that
// offers "facecast.token", in its first message {"type": "auth", "token": C}. Without a key store
// and a token the server is open (loopback only): everyone is the admin of tenant "default".
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "beast.hpp"
#include "facecast/server/keys.hpp"
#include "facecast/server/options.hpp"

namespace facecast::server {

struct Target;  // routes.hpp

/// The tenant of an open server, of the old single token, and of things made before keys.
inline constexpr std::string_view kDefaultTenant = "default";
/// The subprotocol that carries a credential: "facecast.token.<key or token>".
inline constexpr std::string_view kTokenSubprotocol = "facecast.token.";
/// Offered alone (no credential): the first WebSocket message authenticates.
inline constexpr std::string_view kAuthFirstSubprotocol = "facecast.token";

struct Principal {
  std::string tenant{kDefaultTenant};
  std::uint32_t scopes = 0;
  std::string key_id;  // the API key ("" for the open server and the old token)
  // A viewer token: only `channel` (channels:subscribe) or only `rig` (speak).
  bool viewer = false;
  std::string channel, rig;

  bool admin() const { return !viewer && (scopes & kScopeAdmin); }
  bool can(std::uint32_t scope) const { return admin() || (scopes & scope) == scope; }
  /// Throws RequestError(forbidden, 403) naming `what` and the scope unless can(scope).
  void require(std::uint32_t scope, std::string_view what) const;
  /// Whether things of `tenant` are this caller's (admins: everyone's).
  bool owns(std::string_view owner) const { return admin() || owner == tenant; }
};

class Auth {
 public:
  /// Opens the key store as `options.keys` says; throws a one-line Error when it is required and
  /// missing (saying how to make one).
  explicit Auth(const ServerOptions& options);
  ~Auth();
  Auth(const Auth&) = delete;
  Auth& operator=(const Auth&) = delete;

  /// True when every /api path and /ws needs a credential (a key store or a token is there).
  bool enabled() const { return keys_ != nullptr || !token_.empty(); }
  const KeyStore* keys() const { return keys_.get(); }

  /// The caller of a request or WebSocket upgrade. Open server: the admin of tenant "default".
  /// Throws RequestError(unauthorized, 401) when a credential is needed and missing or invalid.
  Principal identify(const Request& req, const Target& target) const;
  /// The caller a credential names (throws 401 like identify).
  Principal identify(std::string_view credential) const;
  /// Whether an upgrade without a credential offers "facecast.token" (first-message auth).
  static bool offers_first_message(const Request& req);
  /// The credential a request carries (Bearer, subprotocol, ?token=), or nullopt.
  static std::optional<std::string> credential(const Request& req, const Target& target);

  /// A signed viewer token (claims: tenant, scope, channel or rig, key, iat, exp); `ttl` seconds,
  /// at most token_max_ttl.
  std::string mint(const Principal& who, std::uint32_t scope, const std::string& channel,
                   const std::string& rig, double ttl) const;
  double max_ttl() const { return max_ttl_; }

 private:
  const std::string& secret() const;  // made on first use, <key store folder>/token_secret
  std::optional<Principal> verify_token(const std::string& token) const;

  std::unique_ptr<KeyStore> keys_;
  std::string token_;
  std::filesystem::path secret_path_;
  double max_ttl_;
  mutable std::mutex secret_mutex_;
  mutable std::string secret_;
};

}  // namespace facecast::server
