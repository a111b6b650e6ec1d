#pragma once
// The facecast.v1 WebSocket protocol (docs/protocol.md): parsing client messages, building server
// messages, and the 24-byte little-endian header of binary media messages.
//
// Errors: every way a request can fail is a facecast::Error (or a RequestError for the codes that
// only the server knows); describe() turns any exception into the protocol's {code, message,
// HTTP status}. It is the one place where exceptions become protocol errors.
#include <array>
#include <cstdint>
#include <exception>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "facecast/core/error.hpp"
#include "facecast/core/utf8.hpp"
#include "facecast/server/options.hpp"
#include "facecast/viseme/import.hpp"
#include "facecast/viseme/options.hpp"

namespace facecast::server {

inline constexpr std::string_view kSubprotocol = "facecast.v1";

// ---- errors -------------------------------------------------------------------------------------

/// Codes of `error` messages and HTTP error bodies.
enum class Code {
  kInvalidInput,  // 400
  kUnauthorized,  // 401
  kForbidden,     // 403
  kNotFound,      // 404
  kMethod,        // 405 ("method_not_allowed")
  kLimit,         // 413 (429 for too many jobs, 503 for too many connections)
  kRateLimited,   // 429
  kUnsupported,   // 400
  kUnavailable,   // 503 (shutting down, too many connections)
  kInternal,      // 500
};
std::string_view to_string(Code code) noexcept;
int http_status(Code code) noexcept;

/// A failure with a server-only code (rate limits, auth) or an explicit HTTP status.
class RequestError : public Error {
 public:
  RequestError(Code code, std::string message, int status = 0)
      : Error(std::move(message), ErrorCode::kInvalidInput), code_(code), status_(status) {}
  Code request_code() const noexcept { return code_; }
  int status() const noexcept { return status_ ? status_ : http_status(code_); }

 private:
  Code code_;
  int status_;
};

struct Problem {
  Code code = Code::kInternal;
  std::string message;
  int status = 500;
};
/// The one translation of exceptions into protocol errors: facecast::Error keeps its code and
/// message, RequestError its code and status, anything else is "internal".
Problem describe(std::exception_ptr error);

// ---- client -> server -------------------------------------------------------------------------

enum class Output { kWeights, kFrames };

struct SpeakRequest {
  std::string id;
  std::optional<std::string> text;
  struct Timestamps {
    viseme::TimestampFormat format = viseme::TimestampFormat::kJson;
    std::string data;  // the file's content (JSON given inline is serialized)
    viseme::PhoneSet phones = viseme::PhoneSet::kAuto;
    std::string text;  // shown as the utterance's text
  };
  std::optional<Timestamps> timestamps;
  viseme::LangMode lang = viseme::LangMode::kAuto;
  std::string rig;  // empty: the server's default rig
  double fps = 60;
  Output output = Output::kWeights;
  bool audio = true;
  viseme::Timing timing = viseme::Timing::kTts;
  int width = 640, height = 480;
  std::string voice = "en-us";
  double rate = 4.5;
  bool idle = true;
  std::string channel;  // empty: this connection's own stream; else a channel it produces
  bool more = false;    // `append` messages add text until `end` (incremental text)
  // An upload (POST /api/audio): `text` is aligned to it, or without text it is lip-synced.
  std::string audio_id;
  // A VMC receiver of the server's vmc_targets allow-list the stream is mirrored to.
  std::string vmc;
};

struct CancelRequest {
  std::string id;
  std::string channel;
};

/// Live shows (docs/protocol.md, "Channels" and "Incremental text").
struct SubscribeRequest {
  std::string channel;
};
struct UnsubscribeRequest {
  std::string channel;
};
struct ProduceRequest {
  std::string channel, token;
};
struct AppendRequest {
  std::string id, text, channel;
};
struct EndRequest {
  std::string id, channel;
};

/// Expression tags over this connection's open live audio stream (docs/protocol.md, "Live audio
/// in").
struct ExpressionRequest {
  std::string tags;
};

/// More of the open aligned live audio stream's text (docs/protocol.md, "Live audio in"); `final`:
/// the text ends with it.
struct AudioTextRequest {
  std::string text;
  bool final = false;
  std::optional<double> start, end;  // both or neither: the text's time in the stream (seconds)
};

struct PingRequest {
  nlohmann::json t;  // echoed (null when absent)
};

using ClientMessage =
    std::variant<SpeakRequest, CancelRequest, PingRequest, SubscribeRequest, UnsubscribeRequest,
                 ProduceRequest, AppendRequest, EndRequest, ExpressionRequest, AudioTextRequest>;

struct ProtocolLimits {
  std::size_t max_text = 2000;  // characters (code points) of text
  int max_fps = 120;
  int max_frame_side = 1920;
  int max_json_depth = 32;  // nesting of arrays/objects in a message, checked before parsing
};

/// Parses one text message. Throws facecast::Error naming the field for malformed JSON, unknown
/// types or fields, wrong types and out-of-range values, and Code::kLimit for text over the limit.
/// `id` (optional) receives the message's id as soon as it is known, so an error can name it.
ClientMessage parse_client_message(std::string_view text, const ProtocolLimits& limits,
                                   std::string* id = nullptr);

/// The live-show messages (subscribe, unsubscribe, produce, append, end) and the `channel` field
/// of speak/cancel; nullopt for other types. `id` is the message's id, already checked.
std::optional<ClientMessage> parse_live_message(const std::string& type, const nlohmann::json& j,
                                                std::string id, const ProtocolLimits& limits);
/// A channel name: 1-64 of A-Z a-z 0-9 _ - . (throws Error naming `field`).
std::string check_channel_name(const nlohmann::json& v, std::string_view field);

/// A message as compact JSON text; text that is not UTF-8 is replaced, never thrown on.
std::string message_text(const nlohmann::json& j);

// ---- server -> client -------------------------------------------------------------------------
// Every JSON message the server sends is built here (docs/protocol.md, "Server -> client").

/// `hello`, on connect: the protocol, `server` ("facecast 1.2.0"), the rig ids, the limits a
/// client must keep to and `lead`.
std::string hello_message(std::string_view server, const std::vector<std::string>& rigs,
                          const ServerOptions& options);

struct StreamStart {
  std::string id;
  std::uint32_t stream = 0;
  Output output = Output::kWeights;
  double fps = 60;
  int frames = 0;
  double duration = 0, speech_duration = 0;  // seconds
  int sample_rate = 0;                       // 0: no audio
  std::size_t samples = 0;
  int width = 0, height = 0;  // frames output
  std::string rig;
  double lead = 0;
};
/// `stream_start`: `names` are the blendshapes of each frame (the body pose's channels follow as
/// "extra": rig::BodyPose::kChannels), `utterance` the viseme engine's timeline.
std::string stream_start_message(const StreamStart& start, const std::vector<std::string>& names,
                                 const nlohmann::json& utterance);

struct StreamEnd {
  std::string id;
  std::optional<std::uint32_t> stream;  // none: cancelled while waiting, never started
  int frames = 0, dropped = 0;
  bool cancelled = false;
};
std::string stream_end_message(const StreamEnd& end);

/// `pong`: echoes the ping's `t`, with the server's uptime in seconds.
std::string pong_message(const nlohmann::json& t, double server_time);

std::string error_message(const std::optional<std::string>& id, const Problem& problem);

/// Channels: the answer to `subscribe` (`playing` is the id of the utterance on air, if any), and
/// the subscriber count when it changed (at most once per presence_interval).
std::string subscribed_message(const std::string& channel, long subscribers,
                               const std::optional<std::string>& playing);
std::string presence_message(const std::string& channel, long subscribers);
/// Incremental text: a piece of utterance `id` placed at `start` seconds of stream `stream`, with
/// its frames [first_frame, end_frame) and audio [first_sample, end_sample).
struct SegmentInfo {
  std::string id;
  std::uint32_t stream = 0;
  int index = 0;
  double start = 0, duration = 0;
  int first_frame = 0, end_frame = 0;
  std::size_t first_sample = 0, end_sample = 0;
};
std::string segment_message(const SegmentInfo& segment, const nlohmann::json& utterance);
/// The stream_start of an open (incremental) utterance: frames, duration, speech_duration and
/// audio.samples are null (unknown yet), "open": true.
std::string open_stream_start(const std::string& stream_start);
/// Answers to `produce` and `unsubscribe`.
std::string producing_message(const std::string& channel);
std::string unsubscribed_message(const std::string& channel);
/// {"error": {"code", "message"}} for HTTP bodies.
std::string error_body(const Problem& problem);

// ---- binary media -----------------------------------------------------------------------------

enum class MediaKind : std::uint8_t { kWeights = 1, kAudio = 2, kJpeg = 3 };
inline constexpr std::size_t kHeaderSize = 24;
inline constexpr std::uint8_t kMediaVersion = 1;

struct MediaHeader {
  MediaKind kind = MediaKind::kWeights;
  std::uint8_t version = kMediaVersion;
  std::uint32_t stream = 0;
  std::uint32_t first = 0;  // first frame (weights, JPEG) or first sample (audio)
  std::uint32_t count = 0;  // frames or samples
  double pts = 0;           // seconds from the start of the utterance's audio
};

/// Writes the 24 header bytes to `out`.
void write_header(const MediaHeader& header, char* out) noexcept;
/// Reads a header; throws Error when `bytes` is shorter than 24 or the kind/version is unknown.
MediaHeader read_header(std::string_view bytes);

/// A whole message: header + float32 (weights) little-endian.
std::string weights_message(std::uint32_t stream, std::uint32_t first, double fps,
                            std::uint32_t count, const float* values, std::size_t values_count);
/// Header + PCM16 little-endian samples.
std::string audio_message(std::uint32_t stream, std::uint32_t first_sample, int sample_rate,
                          const std::int16_t* samples, std::size_t count);
/// Header + JPEG bytes.
std::string jpeg_message(std::uint32_t stream, std::uint32_t frame, double fps,
                         std::string_view jpeg);

/// float32 values of a weights message's payload (after the header).
std::vector<float> read_floats(std::string_view payload);

/// The WebSocket frame header (RFC 6455, 5.2) of a whole server message: final, unmasked, `text`
/// or binary, `size` payload bytes. Returns its length (2, 4 or 10 bytes written to `out`).
std::size_t frame_header(std::array<std::uint8_t, 10>& out, bool text, std::size_t size) noexcept;

}  // namespace facecast::server
