#include "facecast/server/protocol.hpp"

#include "facecast/core/json_limits.hpp"
#include "facecast/rig/motion.hpp"

#include <bit>
#include <cmath>
#include <cstring>

namespace facecast::server {
namespace {

using nlohmann::json;

// ---- little-endian encoding ---------------------------------------------------------------------

void put_u16(char* p, std::uint16_t v) noexcept {
  p[0] = static_cast<char>(v & 0xFF);
  p[1] = static_cast<char>(v >> 8);
}
void put_u32(char* p, std::uint32_t v) noexcept {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<char>((v >> (8 * i)) & 0xFF);
}
void put_u64(char* p, std::uint64_t v) noexcept {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<char>((v >> (8 * i)) & 0xFF);
}
std::uint32_t get_u32(const char* p) noexcept {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i)
    v |= static_cast<std::uint32_t>(static_cast<unsigned char>(p[i])) << (8 * i);
  return v;
}
std::uint64_t get_u64(const char* p) noexcept {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i)
    v |= static_cast<std::uint64_t>(static_cast<unsigned char>(p[i])) << (8 * i);
  return v;
}

std::string with_header(const MediaHeader& h, std::size_t payload) {
  std::string out(kHeaderSize + payload, '\0');
  write_header(h, out.data());
  return out;
}

// ---- JSON field access
// ----------------------------------------------------------------------------

std::string type_name(const json& v) {
  return v.is_number() ? "a number" : std::string("a ") + v.type_name();
}

const std::string& get_string(const json& v, std::string_view field) {
  if (!v.is_string()) throw Error(std::string(field) + ": expected a string, got " + type_name(v));
  return v.get_ref<const std::string&>();
}

double get_number(const json& v, std::string_view field, double lo, double hi) {
  if (!v.is_number()) throw Error(std::string(field) + ": expected a number, got " + type_name(v));
  const double x = v.get<double>();
  if (!std::isfinite(x) || x < lo || x > hi) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "%.*s: %g is outside [%g, %g]", static_cast<int>(field.size()),
                  field.data(), x, lo, hi);
    throw Error(buf);
  }
  return x;
}

bool get_bool(const json& v, std::string_view field) {
  if (!v.is_boolean())
    throw Error(std::string(field) + ": expected true or false, got " + type_name(v));
  return v.get<bool>();
}

// A short name: 1..64 characters from `allowed` (plus ASCII letters and digits).
std::string get_name(const json& v, std::string_view field, std::string_view allowed) {
  const std::string& s = get_string(v, field);
  if (s.empty() || s.size() > 64) throw Error(std::string(field) + ": expected 1 to 64 characters");
  for (const char c : s) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    allowed.find(c) != std::string_view::npos;
    if (!ok) throw Error(std::string(field) + ": '" + s + "' has a character that is not allowed");
  }
  return s;
}

std::string get_id(const json& v) {
  const std::string& s = get_string(v, "id");
  if (s.empty() || utf8_length(s) > 64) throw Error("id: expected 1 to 64 characters");
  for (const char c : s) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7F)
      throw Error("id: control characters are not allowed");
  }
  return s;
}

void check_text_length(const std::string& text, std::string_view field,
                       const ProtocolLimits& limits) {
  const std::size_t n = utf8_length(text);
  if (n > limits.max_text) {
    throw RequestError(Code::kLimit, std::string(field) + ": " + std::to_string(n) +
                                         " characters, the limit is " +
                                         std::to_string(limits.max_text));
  }
}

SpeakRequest parse_speak(const json& j, const ProtocolLimits& limits) {
  SpeakRequest r;
  std::optional<bool> audio;
  std::optional<viseme::Timing> timing;
  std::optional<double> fps;
  for (const auto& [key, v] : j.items()) {
    if (key == "type" || key == "id") continue;
    if (key == "text") {
      r.text = get_string(v, "text");
      const auto more = j.find("more");
      const bool open = more != j.end() && more->is_boolean() && more->get<bool>();
      if (r.text->empty() && !open) throw Error("text: empty");
      check_text_length(*r.text, "text", limits);
    } else if (key == "timestamps") {
      if (!v.is_object())
        throw Error("timestamps: expected an object {format, data, phoneset, text}");
      SpeakRequest::Timestamps ts;
      bool have_format = false, have_data = false;
      for (const auto& [k, x] : v.items()) {
        if (k == "format") {
          ts.format = viseme::parse_timestamp_format(get_string(x, "timestamps.format"));
          have_format = true;
        } else if (k == "data") {
          ts.data = x.is_string() ? x.get<std::string>()
                                  : x.dump(-1, ' ', false, json::error_handler_t::replace);
          have_data = true;
        } else if (k == "phoneset") {
          ts.phones = viseme::parse_phone_set(get_string(x, "timestamps.phoneset"));
        } else if (k == "text") {
          ts.text = get_string(x, "timestamps.text");
          check_text_length(ts.text, "timestamps.text", limits);
        } else {
          throw Error("timestamps: unknown field '" + k + "'");
        }
      }
      if (!have_format) throw Error("timestamps.format: missing");
      if (!have_data) throw Error("timestamps.data: missing");
      r.timestamps = std::move(ts);
    } else if (key == "lang") {
      r.lang = viseme::parse_lang_mode(get_string(v, "lang"));
    } else if (key == "rig") {
      r.rig = get_name(v, "rig", "_-.");
    } else if (key == "fps") {
      fps = get_number(v, "fps", 1, limits.max_fps);
    } else if (key == "output") {
      const std::string& o = get_string(v, "output");
      if (o == "weights") {
        r.output = Output::kWeights;
      } else if (o == "frames") {
        r.output = Output::kFrames;
      } else {
        throw Error("output: '" + o + "' is not weights or frames");
      }
    } else if (key == "audio") {
      audio = get_bool(v, "audio");
    } else if (key == "timing") {
      timing = viseme::parse_timing(get_string(v, "timing"));
    } else if (key == "size") {
      if (!v.is_array() || v.size() != 2 || !v[0].is_number_integer() || !v[1].is_number_integer())
        throw Error("size: expected [width, height] in pixels");
      const auto lo = 16.0, hi = static_cast<double>(limits.max_frame_side);
      r.width = static_cast<int>(get_number(v[0], "size[0]", lo, hi));
      r.height = static_cast<int>(get_number(v[1], "size[1]", lo, hi));
    } else if (key == "voice") {
      r.voice = get_name(v, "voice", "_-+");
    } else if (key == "rate") {
      r.rate = get_number(v, "rate", 0.5, 20);
    } else if (key == "idle") {
      r.idle = get_bool(v, "idle");
    } else if (key == "channel") {
      r.channel = check_channel_name(v, "channel");
    } else if (key == "more") {
      r.more = get_bool(v, "more");
    } else if (key == "audio_id") {
      r.audio_id = get_name(v, "audio_id", "");
    } else if (key == "vmc") {
      r.vmc = get_name(v, "vmc", "_-.");
    } else {
      throw Error("speak: unknown field '" + key + "'");
    }
  }
  if (!r.vmc.empty() && r.output == Output::kFrames)
    throw Error("vmc: a VMC receiver takes weights; not with output frames");
  if (!r.audio_id.empty()) {  // the uploaded audio gives the times: text is optional
    if (r.timestamps || r.more || timing)
      throw Error("audio_id: not with timestamps, more or timing (the audio gives the times)");
    r.audio = audio.value_or(true);
    r.fps = fps.value_or(r.output == Output::kFrames ? 30.0 : 60.0);
    return r;
  }
  if (r.more && r.timestamps) throw Error("more: only with text (append adds text)");
  if (r.more && !r.text) r.text = "";
  if (r.text.has_value() == r.timestamps.has_value())
    throw Error("speak: give exactly one of text and timestamps");
  if (r.timestamps) {
    if (audio.value_or(false))
      throw Error("audio: not available with timestamps (the audio comes from your TTS)");
    r.audio = false;
    r.timing = viseme::Timing::kModel;  // unused: times come from the timestamps
  } else {
    r.audio = audio.value_or(true);
    r.timing = r.audio ? viseme::Timing::kTts : timing.value_or(viseme::Timing::kModel);
  }
  r.fps = fps.value_or(r.output == Output::kFrames ? 30.0 : 60.0);
  return r;
}

}  // namespace

// ---- errors
// ---------------------------------------------------------------------------------------

std::string_view to_string(Code code) noexcept {
  switch (code) {
    case Code::kInvalidInput:
      return "invalid_input";
    case Code::kUnauthorized:
      return "unauthorized";
    case Code::kForbidden:
      return "forbidden";
    case Code::kNotFound:
      return "not_found";
    case Code::kMethod:
      return "method_not_allowed";
    case Code::kLimit:
      return "limit";
    case Code::kRateLimited:
      return "rate_limited";
    case Code::kUnsupported:
      return "unsupported";
    case Code::kUnavailable:
      return "unavailable";
    case Code::kInternal:
      return "internal";
  }
  return "internal";
}

int http_status(Code code) noexcept {
  switch (code) {
    case Code::kInvalidInput:
    case Code::kUnsupported:
      return 400;
    case Code::kUnauthorized:
      return 401;
    case Code::kForbidden:
      return 403;
    case Code::kNotFound:
      return 404;
    case Code::kMethod:
      return 405;
    case Code::kLimit:
      return 413;
    case Code::kRateLimited:
      return 429;
    case Code::kUnavailable:
      return 503;
    case Code::kInternal:
      return 500;
  }
  return 500;
}

Problem describe(std::exception_ptr error) {
  Problem p;
  try {
    std::rethrow_exception(error);
  } catch (const RequestError& e) {
    p.code = e.request_code();
    p.message = e.what();
    p.status = e.status();
  } catch (const Error& e) {
    switch (e.code()) {
      case ErrorCode::kInvalidInput:
        p.code = Code::kInvalidInput;
        break;
      case ErrorCode::kNotFound:
        p.code = Code::kNotFound;
        break;
      case ErrorCode::kUnsupported:
        p.code = Code::kUnsupported;
        break;
      case ErrorCode::kLimit:
        p.code = Code::kLimit;
        break;
      case ErrorCode::kInternal:
        p.code = Code::kInternal;
        break;
    }
    p.message = e.what();
    p.status = http_status(p.code);
  } catch (const std::bad_alloc&) {
    p.code = Code::kInternal;
    p.message = "out of memory";
    p.status = 500;
  } catch (const std::exception& e) {
    p.code = Code::kInternal;
    p.message = std::string("internal error: ") + e.what();
    p.status = 500;
  } catch (...) {
    p.code = Code::kInternal;
    p.message = "internal error";
    p.status = 500;
  }
  return p;
}

// ---- client messages
// --------------------------------------------------------------------------------

ClientMessage parse_client_message(std::string_view text, const ProtocolLimits& limits,
                                   std::string* id) {
  check_json_depth(text, limits.max_json_depth, "message");
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {  // parse_error, out_of_range (number overflow)
    std::string what = e.what();
    if (const auto p = what.find("] "); p != std::string::npos) what = what.substr(p + 2);
    throw Error("malformed JSON: " + what);
  }
  if (!j.is_object()) throw Error("message: expected a JSON object, got " + type_name(j));
  const auto type_it = j.find("type");
  if (type_it == j.end()) throw Error("type: missing");
  const std::string type = get_string(*type_it, "type");
  const auto id_it = j.find("id");
  std::string the_id;
  if (id_it != j.end() &&
      (type == "speak" || type == "cancel" || type == "append" || type == "end")) {
    the_id = get_id(*id_it);
    if (id) *id = the_id;
  }
  if (type == "speak") {
    if (the_id.empty()) throw Error("id: missing");
    SpeakRequest r = parse_speak(j, limits);
    r.id = std::move(the_id);
    return r;
  }
  if (auto live = parse_live_message(type, j, the_id, limits)) return std::move(*live);
  if (type == "cancel") {
    for (const auto& [key, v] : j.items()) {
      if (key != "type" && key != "id") throw Error("cancel: unknown field '" + key + "'");
    }
    if (the_id.empty()) throw Error("id: missing");
    return CancelRequest{std::move(the_id), {}};
  }
  if (type == "ping") {
    PingRequest p;
    for (const auto& [key, v] : j.items()) {
      if (key == "t") {
        p.t = v;
      } else if (key != "type") {
        throw Error("ping: unknown field '" + key + "'");
      }
    }
    return p;
  }
  throw Error(
      "type: unknown message type '" + type +
      "' (speak, cancel, ping, append, end, subscribe, unsubscribe, produce or expression)");
}

// ---- server messages
// --------------------------------------------------------------------------------

std::string hello_message(std::string_view server, const std::vector<std::string>& rigs,
                          const ServerOptions& o) {
  return message_text({{"type", "hello"},
                       {"protocol", kSubprotocol},
                       {"server", server},
                       {"rigs", rigs},
                       {"default_rig", o.default_rig},
                       {"limits",
                        {{"max_text", o.max_text},
                         {"max_message", o.max_message},
                         {"speak_per_minute", o.speak_per_minute},
                         {"speak_burst", o.speak_burst},
                         {"max_queued_speaks", o.max_queued_speaks},
                         {"max_fps", o.max_fps},
                         {"max_frame_side", o.max_frame_side},
                         {"max_utterance_seconds", o.max_utterance_seconds},
                         {"messages_per_second", o.messages_per_second},
                         {"message_burst", o.message_burst}}},
                       {"lead", o.lead}});
}

std::string stream_start_message(const StreamStart& s, const std::vector<std::string>& names,
                                 const json& utterance) {
  const bool frames = s.output == Output::kFrames;
  json audio = nullptr;
  if (s.sample_rate > 0) {
    audio = {{"format", "pcm_s16le"},
             {"sample_rate", s.sample_rate},
             {"channels", 1},
             {"samples", s.samples}};
  }
  return message_text({{"type", "stream_start"},
                       {"id", s.id},
                       {"stream", s.stream},
                       {"output", frames ? "frames" : "weights"},
                       {"fps", s.fps},
                       {"frames", s.frames},
                       {"duration", s.duration},
                       {"speech_duration", s.speech_duration},
                       {"names", names},
                       {"extra", rig::BodyPose::kChannels},
                       {"audio", audio},
                       {"size", frames ? json{s.width, s.height} : json(nullptr)},
                       {"rig", s.rig},
                       {"lead", s.lead},
                       {"utterance", utterance}});
}

std::string stream_end_message(const StreamEnd& e) {
  return message_text({{"type", "stream_end"},
                       {"id", e.id},
                       {"stream", e.stream ? json(*e.stream) : json(nullptr)},
                       {"frames", e.frames},
                       {"dropped", e.dropped},
                       {"cancelled", e.cancelled}});
}

std::string pong_message(const json& t, double server_time) {
  return message_text({{"type", "pong"}, {"t", t}, {"server_time", server_time}});
}

std::string error_message(const std::optional<std::string>& id, const Problem& problem) {
  return message_text({{"type", "error"},
                       {"id", id ? json(*id) : json(nullptr)},
                       {"code", to_string(problem.code)},
                       {"message", problem.message}});
}

std::string error_body(const Problem& problem) {
  return message_text(
      {{"error", {{"code", to_string(problem.code)}, {"message", problem.message}}}});
}

// ---- binary media
// -----------------------------------------------------------------------------------

void write_header(const MediaHeader& h, char* out) noexcept {
  out[0] = static_cast<char>(h.kind);
  out[1] = static_cast<char>(h.version);
  put_u16(out + 2, 0);
  put_u32(out + 4, h.stream);
  put_u32(out + 8, h.first);
  put_u32(out + 12, h.count);
  put_u64(out + 16, std::bit_cast<std::uint64_t>(h.pts));
}

MediaHeader read_header(std::string_view bytes) {
  if (bytes.size() < kHeaderSize)
    throw Error("binary message: " + std::to_string(bytes.size()) +
                " bytes, shorter than the header");
  MediaHeader h;
  const auto kind = static_cast<unsigned char>(bytes[0]);
  if (kind < 1 || kind > 3) throw Error("binary message: unknown kind " + std::to_string(kind));
  h.kind = static_cast<MediaKind>(kind);
  h.version = static_cast<std::uint8_t>(bytes[1]);
  if (h.version != kMediaVersion)
    throw Error("binary message: unknown version " + std::to_string(h.version));
  h.stream = get_u32(bytes.data() + 4);
  h.first = get_u32(bytes.data() + 8);
  h.count = get_u32(bytes.data() + 12);
  h.pts = std::bit_cast<double>(get_u64(bytes.data() + 16));
  return h;
}

std::string weights_message(std::uint32_t stream, std::uint32_t first, double fps,
                            std::uint32_t count, const float* values, std::size_t values_count) {
  MediaHeader h{MediaKind::kWeights, kMediaVersion, stream, first, count, first / fps};
  std::string out = with_header(h, values_count * 4);
  char* p = out.data() + kHeaderSize;
  if constexpr (std::endian::native == std::endian::little) {
    std::memcpy(p, values, values_count * 4);
  } else {
    for (std::size_t i = 0; i < values_count; ++i)
      put_u32(p + 4 * i, std::bit_cast<std::uint32_t>(values[i]));
  }
  return out;
}

std::string audio_message(std::uint32_t stream, std::uint32_t first_sample, int sample_rate,
                          const std::int16_t* samples, std::size_t count) {
  MediaHeader h{MediaKind::kAudio,
                kMediaVersion,
                stream,
                first_sample,
                static_cast<std::uint32_t>(count),
                static_cast<double>(first_sample) / sample_rate};
  std::string out = with_header(h, count * 2);
  char* p = out.data() + kHeaderSize;
  for (std::size_t i = 0; i < count; ++i)
    put_u16(p + 2 * i, static_cast<std::uint16_t>(samples[i]));
  return out;
}

std::string jpeg_message(std::uint32_t stream, std::uint32_t frame, double fps,
                         std::string_view jpeg) {
  MediaHeader h{MediaKind::kJpeg, kMediaVersion, stream, frame, 1, frame / fps};
  std::string out = with_header(h, jpeg.size());
  std::memcpy(out.data() + kHeaderSize, jpeg.data(), jpeg.size());
  return out;
}

std::vector<float> read_floats(std::string_view payload) {
  if (payload.size() % 4) throw Error("weights payload: size is not a multiple of 4");
  std::vector<float> out(payload.size() / 4);
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i] = std::bit_cast<float>(get_u32(payload.data() + 4 * i));
  return out;
}

std::size_t frame_header(std::array<std::uint8_t, 10>& out, bool text, std::size_t size) noexcept {
  out[0] = static_cast<std::uint8_t>(0x80 | (text ? 0x1 : 0x2));  // FIN, text or binary
  if (size < 126) {
    out[1] = static_cast<std::uint8_t>(size);
    return 2;
  }
  if (size <= 0xFFFF) {
    out[1] = 126;
    out[2] = static_cast<std::uint8_t>(size >> 8);
    out[3] = static_cast<std::uint8_t>(size);
    return 4;
  }
  out[1] = 127;
  for (int i = 0; i < 8; ++i) out[2 + i] = static_cast<std::uint8_t>(size >> (56 - 8 * i));
  return 10;
}

std::string message_text(const json& j) {
  return j.dump(-1, ' ', false, json::error_handler_t::replace);
}

}  // namespace facecast::server
