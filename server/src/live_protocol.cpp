// The live-show messages of facecast.v1 (docs/protocol.md, "Channels" and "Incremental text"):
// subscribe, unsubscribe, produce, append, end and cancel with a channel; subscribed, presence and
// segment from the server.
#include <nlohmann/json.hpp>

#include "facecast/server/protocol.hpp"

namespace facecast::server {
namespace {

using nlohmann::json;

const std::string& string_field(const json& v, std::string_view field) {
  if (!v.is_string()) throw Error(std::string(field) + ": expected a string");
  return v.get_ref<const std::string&>();
}

// Reads the fields of `j` named in `fields` (plus "type" and "id"); any other field is an error.
template <class F>
void read_fields(const json& j, std::string_view type,
                 std::initializer_list<std::string_view> fields, F&& read) {
  for (const auto& [key, v] : j.items()) {
    if (key == "type" || key == "id") continue;
    bool known = false;
    for (const auto f : fields) known = known || f == key;
    if (!known) throw Error(std::string(type) + ": unknown field '" + key + "'");
    read(key, v);
  }
}

std::string need_channel(const std::string& channel, std::string_view type) {
  if (channel.empty()) throw Error(std::string(type) + ": channel: missing");
  return channel;
}

}  // namespace

std::string check_channel_name(const json& v, std::string_view field) {
  const std::string& s = string_field(v, field);
  if (s.empty() || s.size() > 64) throw Error(std::string(field) + ": expected 1 to 64 characters");
  for (const char c : s) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '-' || c == '.';
    if (!ok) throw Error(std::string(field) + ": '" + s + "' has a character that is not allowed");
  }
  return s;
}

std::optional<ClientMessage> parse_live_message(const std::string& type, const json& j,
                                                std::string id, const ProtocolLimits& limits) {
  std::string channel, text, token;
  bool have_text = false;
  const auto read = [&](const std::string& key, const json& v) {
    if (key == "channel") {
      channel = check_channel_name(v, "channel");
    } else if (key == "text") {
      text = string_field(v, "text");
      have_text = true;
    } else if (key == "token") {
      token = string_field(v, "token");
    } else if (key == "tags") {
      text = string_field(v, "tags");
      have_text = true;
    }
  };
  if (type == "expression") {
    read_fields(j, type, {"tags"}, read);
    if (!have_text) throw Error("expression: tags: missing");
    if (utf8_length(text) > limits.max_text)
      throw RequestError(Code::kLimit,
                         "tags: more than " + std::to_string(limits.max_text) + " characters");
    return ExpressionRequest{std::move(text)};
  }
  if (type == "audio_text") {
    AudioTextRequest r;
    read_fields(j, type, {"text", "final", "start", "end"},
                [&](const std::string& key, const json& v) {
                  if (key == "final") {
                    if (!v.is_boolean()) throw Error("audio_text: final: expected true or false");
                    r.final = v.get<bool>();
                  } else if (key == "start" || key == "end") {
                    if (!v.is_number()) throw Error("audio_text: " + key + ": expected seconds");
                    (key == "start" ? r.start : r.end) = v.get<double>();
                  } else {
                    read(key, v);
                  }
                });
    if (!have_text && !r.final) throw Error("audio_text: text: missing");
    if (r.start.has_value() != r.end.has_value())
      throw Error("audio_text: start and end come together (or neither)");
    if (utf8_length(text) > limits.max_text)
      throw RequestError(Code::kLimit,
                         "text: more than " + std::to_string(limits.max_text) + " characters");
    r.text = std::move(text);
    return r;
  }
  if (type == "subscribe" || type == "unsubscribe") {
    read_fields(j, type, {"channel"}, read);
    if (type == "subscribe") return SubscribeRequest{need_channel(channel, type)};
    return UnsubscribeRequest{need_channel(channel, type)};
  }
  if (type == "produce") {
    read_fields(j, type, {"channel", "token"}, read);
    return ProduceRequest{need_channel(channel, type), token};
  }
  if (type == "append" || type == "end" || (type == "cancel" && j.contains("channel"))) {
    read_fields(j, type,
                type == "append" ? std::initializer_list<std::string_view>{"channel", "text"}
                                 : std::initializer_list<std::string_view>{"channel"},
                read);
    if (id.empty()) throw Error("id: missing");
    if (type == "cancel") return CancelRequest{std::move(id), channel};
    if (type == "end") return EndRequest{std::move(id), channel};
    if (!have_text) throw Error("append: text: missing");
    if (utf8_length(text) > limits.max_text)
      throw RequestError(Code::kLimit, "text: more than " + std::to_string(limits.max_text) +
                                           " characters in one append");
    return AppendRequest{std::move(id), std::move(text), channel};
  }
  return std::nullopt;
}

std::string subscribed_message(const std::string& channel, long subscribers,
                               const std::optional<std::string>& playing) {
  return message_text({{"type", "subscribed"},
                       {"channel", channel},
                       {"subscribers", subscribers},
                       {"playing", playing ? json(*playing) : json(nullptr)}});
}

std::string presence_message(const std::string& channel, long subscribers) {
  return message_text({{"type", "presence"}, {"channel", channel}, {"subscribers", subscribers}});
}

std::string segment_message(const SegmentInfo& s, const json& utterance) {
  return message_text({{"type", "segment"},
                       {"id", s.id},
                       {"stream", s.stream},
                       {"index", s.index},
                       {"start", s.start},
                       {"duration", s.duration},
                       {"first_frame", s.first_frame},
                       {"end_frame", s.end_frame},
                       {"first_sample", s.first_sample},
                       {"end_sample", s.end_sample},
                       {"utterance", utterance}});
}

std::string open_stream_start(const std::string& stream_start) {
  json j = json::parse(stream_start);
  j["frames"] = nullptr;
  j["duration"] = nullptr;
  j["speech_duration"] = nullptr;
  if (j["audio"].is_object()) j["audio"]["samples"] = nullptr;
  j["open"] = true;
  return message_text(j);
}

std::string producing_message(const std::string& channel) {
  return message_text({{"type", "producing"}, {"channel", channel}});
}

std::string unsubscribed_message(const std::string& channel) {
  return message_text({{"type", "unsubscribed"}, {"channel", channel}});
}

}  // namespace facecast::server
