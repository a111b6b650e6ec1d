#include "access.hpp"

#include <chrono>

#include "channel.hpp"
#include "clock.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/json_limits.hpp"
#include "log.hpp"
#include "responses.hpp"
#include "routes.hpp"

namespace facecast::server {
namespace {

using nlohmann::json;

[[noreturn]] void no_rig(const std::string& id) {
  throw Error("rig '" + id + "' does not exist", ErrorCode::kNotFound);
}

}  // namespace

std::shared_ptr<Channel> Access::owned_channel(const Principal& who,
                                               const std::string& name) const {
  auto c = channels_ ? channels_->find(name) : nullptr;
  if (!c || !who.owns(c->tenant()))
    throw Error("channel: '" + name + "' does not exist", ErrorCode::kNotFound);
  return c;
}

void Access::check_speak(const Principal& who, const SpeakRequest& r) const {
  if (r.channel.empty())
    who.require(kScopeSpeak, "speak");
  else
    who.require(kScopeChannelsProduce, "speak on a channel");
  const RigInfo rig = usable_rig(who, r.rig);
  if (who.viewer && rig.id != who.rig)
    throw RequestError(Code::kForbidden, "this token may speak only with rig '" + who.rig + "'");
  if (!r.audio_id.empty()) {
    const auto owner = uploads_.owner(r.audio_id);
    if (!owner || !who.owns(*owner))
      throw Error("audio_id '" + r.audio_id + "': no such upload (POST /api/audio; uploads expire)",
                  ErrorCode::kNotFound);
  }
}

bool rig_listed(const Principal& who, const RigInfo& rig) {
  return rig.builtin || who.owns(rig.tenant);
}

bool rig_usable(const Principal& who, const RigInfo& rig) {
  return rig.is_public || rig_listed(who, rig);
}

RigInfo Access::usable_rig(const Principal& who, const std::string& id) const {
  const std::string resolved = rigs_.resolve(id);
  const auto info = rigs_.find(resolved);
  if (!info || !rig_usable(who, *info)) no_rig(resolved);
  return *info;
}

void Access::authorize_message(const Principal& who, const ClientMessage& message) const {
  std::visit(
      [&](const auto& m) {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, SpeakRequest>) {
          check_speak(who, m);
        } else if constexpr (std::is_same_v<T, CancelRequest> || std::is_same_v<T, AppendRequest> ||
                             std::is_same_v<T, EndRequest>) {
          if (m.channel.empty())
            who.require(kScopeSpeak, "speak");
          else
            who.require(kScopeChannelsProduce, "a channel's utterances");
        } else if constexpr (std::is_same_v<T, ExpressionRequest>) {
          who.require(kScopeSpeak, "expression");
        } else if constexpr (std::is_same_v<T, AudioTextRequest>) {
          who.require(kScopeSpeak, "audio_text");
        } else if constexpr (std::is_same_v<T, SubscribeRequest>) {
          who.require(kScopeChannelsSubscribe, "subscribe");
          if (who.viewer && m.channel != who.channel)
            throw RequestError(Code::kForbidden,
                               "this token may subscribe only to channel '" + who.channel + "'");
          (void)owned_channel(who, m.channel);
        } else if constexpr (std::is_same_v<T, ProduceRequest>) {
          who.require(kScopeChannelsProduce, "produce");
          (void)owned_channel(who, m.channel);
        }
        // ping, unsubscribe: anyone connected
      },
      message);
}

void Access::authorize_live_audio(const Principal& who) const {
  who.require(kScopeSpeak, "live audio");
  const RigInfo rig = usable_rig(who, "");
  if (who.viewer && rig.id != who.rig)
    throw RequestError(Code::kForbidden, "this token may speak only with rig '" + who.rig + "'");
}

http::message_generator Access::post_token(const Request& req, const Principal& who) const {
  if (who.viewer)
    throw RequestError(Code::kForbidden, "POST /api/tokens needs a key, not a viewer token");
  check_json_depth(req.body(), 8, "body");
  const json body = json::parse(req.body(), nullptr, false);
  if (!body.is_object())
    throw Error("body: expected a JSON object {\"scope\", \"channel\"|\"rig\"}");
  std::string scope_name, channel, rig;
  double ttl = std::min(600.0, auth_.max_ttl());
  for (const auto& [k, v] : body.items()) {
    if (k == "scope" || k == "channel" || k == "rig") {
      if (!v.is_string()) throw Error(k + ": expected a string");
      (k == "scope" ? scope_name : k == "channel" ? channel : rig) = v.get<std::string>();
    } else if (k == "ttl") {
      if (!v.is_number() || !(v.get<double>() >= 1 && v.get<double>() <= auth_.max_ttl()))
        throw Error("ttl: expected seconds in 1.." + std::to_string(auth_.max_ttl()) +
                    " (token_max_ttl)");
      ttl = v.get<double>();
    } else {
      throw Error("body: unknown field '" + k + "'");
    }
  }
  json out;
  std::uint32_t scope = 0;
  if (scope_name == "channels:subscribe") {
    if (channel.empty() || !rig.empty())
      throw Error("channel: a channels:subscribe token names one channel (and no rig)");
    scope = kScopeChannelsSubscribe;
    who.require(scope, "a channels:subscribe token");
    (void)owned_channel(who, channel);
    out["channel"] = channel;
  } else if (scope_name == "speak") {
    if (!channel.empty()) throw Error("channel: a speak token names a rig, not a channel");
    scope = kScopeSpeak;
    who.require(scope, "a speak token");
    rig = usable_rig(who, rig).id;  // "" or absent: the default rig
    out["rig"] = rig;
  } else {
    throw Error("scope: '" + scope_name + "' is not channels:subscribe or speak");
  }
  const std::string token = auth_.mint(who, scope, channel, rig, ttl);
  const double now = unix_now();
  out["token"] = token;
  out["scope"] = scope_name;
  out["tenant"] = who.tenant;
  out["expires_in"] = std::floor(ttl);
  out["expires_at"] = std::floor(now + ttl);
  log::info("token_minted", {{"tenant", who.tenant},
                             {"key", who.key_id},
                             {"scope", scope_name},
                             {"channel", channel},
                             {"rig", rig},
                             {"ttl", ttl}});
  return reply_.json(req, http::status::created, out);
}

}  // namespace facecast::server
