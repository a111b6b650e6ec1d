#pragma once
// Tenants apart (docs/security.md): what a caller may see and use. Rigs, jobs
// (and their videos), uploaded audio and channels belong to a tenant; a caller sees its own (an
// admin sees all). Built-in rigs and rigs marked public can be used (spoken with, their GLB
// loaded without a key) by anyone, but are listed only to their tenant. What another tenant owns
// answers 404, as if it did not exist.
#include <memory>
#include <string>

#include "audio_uploads.hpp"
#include "auth.hpp"
#include "beast.hpp"
#include "facecast/server/protocol.hpp"
#include "rigs.hpp"

namespace facecast::server {

/// GET /api/rigs lists it to `who`: built in, or `who`'s (admins: all).
bool rig_listed(const Principal& who, const RigInfo& rig);
/// `who` may use it (speak with it, render it, build from it, load its GLB): listed, or public.
bool rig_usable(const Principal& who, const RigInfo& rig);
class ChannelRegistry;
class Channel;
class Responses;

/// Who may use what: checks a caller (a Principal from auth.hpp) against the rigs, uploads and
/// channels it names.
class Access {
 public:
  /// `channels`: the server's channel set (set before the first request; null: none).
  Access(Auth& auth, const RigRegistry& rigs, AudioUploads& uploads,
         const std::shared_ptr<ChannelRegistry>& channels, const Responses& reply)
      : auth_(auth), rigs_(rigs), uploads_(uploads), channels_(channels), reply_(reply) {}

  /// The rig `id` ("" for the default rig) when `who` may use it; throws Error(not found).
  RigInfo usable_rig(const Principal& who, const std::string& id) const;

  /// Checks a WebSocket message against its sender: the scope it needs (speak; channels:produce
  /// for a channel's speak/append/end/cancel and produce; channels:subscribe), the rig, the
  /// upload and the channel it names, and a viewer token's one channel or rig. Throws 403 / 404.
  void authorize_message(const Principal& who, const ClientMessage& message) const;
  /// Live audio in (binary): speak, with the default rig.
  void authorize_live_audio(const Principal& who) const;

  /// POST /api/tokens: body {"scope": "channels:subscribe", "channel": C} or {"scope": "speak",
  /// "rig": R}, optional "ttl" (seconds, at most token_max_ttl); the caller (a key, not a viewer
  /// token) must hold that scope and own the channel / be able to use the rig. Answers 201
  /// {"token", "scope", "channel" | "rig", "tenant", "expires_at", "expires_in"}.
  http::message_generator post_token(const Request& req, const Principal& who) const;

 private:
  std::shared_ptr<Channel> owned_channel(const Principal& who, const std::string& name) const;
  void check_speak(const Principal& who, const SpeakRequest& r) const;

  Auth& auth_;
  const RigRegistry& rigs_;
  AudioUploads& uploads_;
  const std::shared_ptr<ChannelRegistry>& channels_;
  const Responses& reply_;
};

}  // namespace facecast::server
