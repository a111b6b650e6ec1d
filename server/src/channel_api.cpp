// The channels' HTTP API: GET /api/channels/{c} and POST /api/channels/{c}/speak.
#include <future>

#include "access.hpp"
#include "channel.hpp"
#include "routes.hpp"
#include "services.hpp"

namespace facecast::server {

namespace {

// POST /api/channels/{c}/speak: the body is a `speak` message (type and id optional).
http::message_generator post_channel_speak(Services& services, const Request& req, Channel& channel,
                                           const Principal& who) {
  nlohmann::json body;
  try {
    body = nlohmann::json::parse(req.body());
  } catch (const nlohmann::json::exception&) {
    throw Error("body: malformed JSON");
  }
  if (!body.is_object()) throw Error("body: expected a JSON object (a speak message)");
  body["type"] = "speak";
  if (!body.contains("id")) body["id"] = "h" + std::to_string(services.sessions.peek_stream_id());
  body["channel"] = channel.name();
  ClientMessage m = parse_client_message(body.dump(), services.limits);
  services.access.authorize_message(who, m);  // the rig and the upload it names
  const std::string id = std::get<SpeakRequest>(m).id;
  // Runs on a worker (POST is heavy): waiting for the channel's strand blocks no I/O thread.
  auto answer = std::make_shared<std::promise<std::optional<Problem>>>();
  auto done = answer->get_future();
  channel.request(std::move(m), {},
                  [answer](std::optional<Problem> p) { answer->set_value(std::move(p)); });
  if (done.wait_for(std::chrono::seconds(10)) != std::future_status::ready)
    throw RequestError(Code::kUnavailable, "channel '" + channel.name() + "' did not answer");
  if (const auto problem = done.get())
    throw RequestError(problem->code, problem->message, problem->status);
  return services.responses.json(req, http::status::accepted,
                                 {{"channel", channel.name()}, {"id", id}});
}

}  // namespace

http::message_generator channel_api(Services& services, const Request& req, const Target& target) {
  std::string_view rest =
      std::string_view(target.path).substr(std::string_view("/api/channels/").size());
  const auto slash = rest.find('/');
  const std::string name(rest.substr(0, slash));
  const std::string_view tail = slash == std::string_view::npos ? "" : rest.substr(slash);
  const auto channel = services.channels ? services.channels->find(name) : nullptr;
  if (tail == "/speak") {
    if (req.method() != http::verb::post)
      throw RequestError(Code::kMethod, "/api/channels/{c}/speak takes POST");
    // The channel's producer token, or (with keys) a key of its tenant with channels:produce.
    const auto given = Auth::credential(req, target);
    std::optional<Principal> who;
    if (channel && given && channel->producer_token_ok(*given)) {
      who = Principal{channel->tenant(), kScopeChannelsProduce, {}, false, {}, {}};
    } else if (services.auth.enabled()) {
      who = services.auth.identify(req, target);
      if (who->viewer) throw RequestError(Code::kForbidden, "a viewer token cannot speak here");
      who->require(kScopeChannelsProduce, "POST /api/channels/{c}/speak");
    } else if (!channel) {
      throw Error("channel '" + name + "' does not exist", ErrorCode::kNotFound);
    } else {
      throw RequestError(Code::kUnauthorized,
                         "the channel's producer token is required (Authorization: Bearer)");
    }
    if (!channel || !who->owns(channel->tenant()))
      throw Error("channel '" + name + "' does not exist", ErrorCode::kNotFound);
    return post_channel_speak(services, req, *channel, *who);
  }
  const Principal who = services.auth.identify(req, target);
  if (who.viewer) throw RequestError(Code::kForbidden, "a viewer token cannot call " + target.path);
  if (!tail.empty() || !channel || !who.owns(channel->tenant()))
    throw Error("not found: " + target.path, ErrorCode::kNotFound);
  if (req.method() != http::verb::get && req.method() != http::verb::head)
    throw RequestError(Code::kMethod, "/api/channels/{c} takes GET");
  who.require(kScopeChannelsSubscribe, "GET /api/channels/{c}");
  return services.responses.json(req, http::status::ok,
                                 {{"channel", channel->name()},
                                  {"subscribers", channel->total_subscribers()},
                                  {"local_subscribers", channel->subscribers()}});
}

}  // namespace facecast::server
