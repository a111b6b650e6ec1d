#pragma once
// Tenants apart (docs/security.md): what a caller may see and use. Rigs, jobs
// (and their videos), uploaded audio and channels belong to a tenant; a caller sees its own (an
// admin sees all). Built-in rigs and rigs marked public can be used (spoken with, their GLB
// loaded without a key) by anyone, but are listed only to their tenant. What another tenant owns
// answers 404, as if it did not exist.
#include <string>

#include "auth.hpp"
#include "beast.hpp"
#include "facecast/server/protocol.hpp"
#include "rigs.hpp"

namespace facecast::server {

struct State;

/// GET /api/rigs lists it to `who`: built in, or `who`'s (admins: all).
bool rig_listed(const Principal& who, const RigInfo& rig);
/// `who` may use it (speak with it, render it, build from it, load its GLB): listed, or public.
bool rig_usable(const Principal& who, const RigInfo& rig);
/// The rig `id` ("" for the default rig) when `who` may use it; throws Error(not found) otherwise.
RigInfo usable_rig(const State& state, const Principal& who, const std::string& id);

/// Checks a WebSocket message against its sender: the scope it needs (speak; channels:produce
/// for a channel's speak/append/end/cancel and produce; channels:subscribe), the rig, the upload
/// and the channel it names, and a viewer token's one channel or rig. Throws 403 / 404.
void authorize_message(State& state, const Principal& who, const ClientMessage& message);
/// Live audio in (binary): speak, with the default rig.
void authorize_live_audio(State& state, const Principal& who);

/// POST /api/tokens: body {"scope": "channels:subscribe", "channel": C} or {"scope": "speak",
/// "rig": R}, optional "ttl" (seconds, at most token_max_ttl); the caller (a key, not a viewer
/// token) must hold that scope and own the channel / be able to use the rig. Answers 201 {"token",
/// "scope", "channel" | "rig", "tenant", "expires_at", "expires_in"}.
http::message_generator post_token(State& state, const Request& req, const Principal& who);

}  // namespace facecast::server
