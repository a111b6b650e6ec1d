#pragma once
// Every setting and limit of `facecast serve`. The defaults here mirror configs/server.json (a
// test checks that they agree); docs/server.md ("Configuration") and docs/protocol.md document
// each one.
#include <cstddef>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "facecast/rig/decode_limits.hpp"
#include "facecast/rig/rest_pose.hpp"

namespace facecast::server {

/// VMC receivers: a channel's (channels.<name>.vmc) or a private speak's (vmc_targets.<name>).
/// At namespace scope, not in ServerOptions: clang 14 takes a nested class with member
/// initializers for one it cannot default-construct while the outer class is incomplete.
struct VmcReceivers {
  std::vector<std::string> targets;    // "HOST:PORT" each
  std::string names = "perfect-sync";  // perfect-sync | vrm0 | vrm1
};

struct ServerOptions {
  // Where to listen. Any host other than a loopback address requires a key store (or `token`).
  std::string host = "127.0.0.1";
  int port = 8080;  // 0 picks a free port
  // Rigs and rendered videos live here (relative: to the working folder).
  std::filesystem::path data = "data";
  // The single admin key of older versions (tenant "default", every scope): when set, /api/* and
  // /ws need it or a key from the key store ("Authorization: Bearer T", or "?token=T").
  std::string token;
  // API keys (docs/security.md; `facecast keys create`): "auto" loads
  // <data>/keys.sqlite3 when it exists; "required" (true in the config) refuses to start without
  // it; any other string is the store's path (required). With a store, every /api/* path and /ws
  // needs a key or a viewer token; without one (and without `token`) the server is open, which
  // only a loopback `host` allows.
  std::string keys = "auto";
  double token_max_ttl = 3600;  // longest life of a viewer token (POST /api/tokens), seconds
  // Static files: the web client and the pinned three.js package (relative: to the project root,
  // the folder above configs/).
  std::filesystem::path web_root = "web";
  std::filesystem::path three_root = "node_modules/three";
  std::filesystem::path three_vrm_root = "node_modules/@pixiv/three-vrm/lib";  // VRM avatars
  std::filesystem::path client_root = "clients/js";  // the JS client the web page imports
  // The rig a `speak` without "rig" uses: "default" is the built-in avatar.
  std::string default_rig = "default";
  // How the avatars stand in frames and streams: "rest", "bind" or a pose file (rig/rest_pose.hpp,
  // docs/cli.md#pose-files), read when the options are loaded.
  rig::Pose pose;

  // Threads.
  int io_threads = 2;   // network I/O (one strand per connection)
  int workers = 2;      // speech analysis and frame rendering
  int job_workers = 1;  // rig builds and video renders

  // Limits.
  int max_connections = 2000;         // HTTP + WebSocket connections at once
  std::size_t max_message = 65536;    // bytes of one WebSocket message (larger: close 1009)
  std::size_t max_text = 2000;        // characters of speak text
  std::size_t max_body = 65536;       // bytes of a request body other than uploads
  std::size_t max_upload = 67108864;  // bytes of a POST /api/rigs or /api/render body
  double speak_per_minute = 60;       // speak rate per connection (token bucket)...
  int speak_burst = 10;               // ...with this many at once
  int max_queued_speaks = 16;         // playing + waiting utterances per connection
  int max_fps = 120;                  // highest fps a speak may ask for
  int max_frame_side = 1920;          // largest width/height of frames and videos
  int max_jobs = 8;                   // rig builds and renders queued or running
  double max_render_seconds = 120;    // longest video POST /api/render makes
  double job_retention = 604800;      // seconds ended jobs and their videos are kept (0: forever)
  // Bounds on what one peer can make the server spend (docs/security.md).
  int max_json_depth = 32;             // nesting of arrays/objects in messages and JSON bodies
  double max_utterance_seconds = 600;  // longest utterance (timestamps, text, audio)
  std::size_t max_piece = 400;         // characters of one incremental-text piece (cut at spaces)
  double messages_per_second = 200;    // WebSocket messages per connection (token bucket)...
  int message_burst = 400;             // ...with this many at once; over it: close 1008
  std::size_t max_control_bytes = 65536;    // WebSocket control frames (pongs) queued unread: close
  int max_connections_per_address = 256;    // connections at once from one client address
  std::size_t max_body_memory = 268435456;  // request body bytes held at once, all requests
  double live_audio_ahead = 10;  // live audio in may run this many seconds ahead of real time
  // Peers whose X-Forwarded-For is believed (the client is its last address not in this list);
  // any other peer is the client itself. IP addresses, e.g. ["127.0.0.1"] behind a local nginx.
  std::vector<std::string> trusted_proxies;
  double max_audio_seconds = 120;    // longest POST /api/audio, decoded (413 beyond)
  double audio_decode_timeout = 10;  // seconds ffmpeg may decode an upload; then killed (413)
  // What an uploaded avatar, rig mesh or photo may make the server decode (configs: "decode";
  // the fields and defaults of rig::DecodeLimits): checked before parsing, decoding or
  // allocating, answered 413 with the file and field.
  rig::DecodeLimits decode;

  // Streaming (the rules are in docs/algorithms.md#stream-pacing).
  double lead = 0.1;          // frames are sent this many seconds before their presentation time
  double min_tick = 0.034;    // at least this long between two sends of one stream (s)
  double channel_tick = 0.1;  // a channel's weights go out this often, up to this early (s)
  double audio_chunk = 0.2;   // seconds of PCM per audio message
  double cancel_fade = 0.2;   // seconds to fade to rest after cancel
  int write_queue = 64;       // media messages queued per connection before dropping
  double slow_client_grace = 2.0;  // a queue not drained for this long closes the socket (1008)
  double close_timeout = 2.0;      // a close handshake that takes longer ends with a hard close
  int frames_in_flight = 2;        // frames mode: renders running per stream
  int jpeg_quality = 80;
  int render_contexts = 2;  // GL contexts per renderer (rig and size)
  int max_renderers = 4;    // renderers kept (rig, size), least recently used dropped
  int send_buffer = 0;      // SO_SNDBUF of accepted sockets in bytes (0: the system's)

  // Timeouts (seconds).
  double http_timeout = 30;          // reading a request / writing a response
  double ws_handshake_timeout = 30;  // WebSocket handshake and close
  double ws_idle_timeout = 60;       // no traffic: ping at half of it, close at it
  double shutdown_timeout = 3;       // SIGINT/SIGTERM: hard stop after this long
  double drain_timeout = 10;         // SIGTERM: running utterances may finish for this long

  // Origin check of the WebSocket upgrade and of every POST/PUT/PATCH/DELETE: browsers may come
  // from the server's own origin and from these ("*" allows any). Clients that send no Origin (not
  // browsers) are allowed.
  std::vector<std::string> allowed_origins;
  // Host check of every request (against DNS rebinding): names served besides localhost,
  // 127.0.0.1, [::1] and IP addresses, any port ("*": any Host). Others get 421.
  std::vector<std::string> allowed_hosts;
  // CORS, off by default: pages of these origins ("https://app.example") may call the API
  // (preflight answered, Access-Control-Allow-Origin sent); they pass the Origin check too.
  std::vector<std::string> cors_origins;

  std::string log_level = "info";  // debug | info | warn | error

  // Live shows (docs/protocol.md, "Channels"): the channels that exist, each with the token its
  // producers present; anyone allowed on /ws may subscribe.
  // A channel published as a live video (RTMP: H.264 + AAC in FLV, through ffmpeg); see
  // docs/protocol.md, "Live video out".
  struct Rtmp {
    std::string url;  // rtmp://host/app/key; empty: not published
    int width = 640, height = 360;
    double fps = 30;
    int video_kbps = 2000;
    int audio_kbps = 128;
    double delay = 0.5;  // seconds from a stream's start to its first published frame
  };
  struct Channel {
    std::string name;
    std::string producer_token;
    std::string tenant = "default";  // whose channel: keys of other tenants cannot use it
    // channels.<name>.vmc: the show mirrored to VMC receivers (server/src/vmc_out.hpp).
    using Vmc = VmcReceivers;
    std::optional<Vmc> vmc{};
  };
  std::vector<Channel> channels;
  // vmc_targets: VMC receivers a private speak may name ("vmc": "<name>"); clients never give an
  // address, so the server's UDP goes only where this allow-list says.
  std::map<std::string, Channel::Vmc> vmc_targets;
  // What a tenant may keep on disk: its stored rigs and its jobs' files (0: no limit), and how
  // long a stored rig is kept (seconds from when it was stored; 0: forever). storage.hpp.
  std::uint64_t tenant_disk_quota = 4'000'000'000;
  double rig_retention = 0;
  std::map<std::string, Rtmp> rtmp;  // by channel name (configs: channels.<name>.rtmp)
  double presence_interval = 1.0;    // seconds between two `presence` messages of a channel
  double channel_idle = 10;          // idle-life streams of this length between utterances (0: off)

  // Many instances (docs/protocol.md, "Many instances"). Rigs and rendered videos go into
  // `shared_dir` when set (a folder every instance mounts), else under `data`.
  std::filesystem::path shared_dir;
  // With a Redis url, channels reach subscribers on every instance (pub/sub), rig and render jobs
  // go through a Redis queue any instance's workers take, and job records live in Redis. Without
  // one (the default) the instance works alone.
  struct Redis {
    std::string url;                   // redis://[:password@]host[:port][/db]; empty: no Redis
    std::string prefix = "facecast:";  // of every key and pub/sub channel
    double heartbeat = 1.0;            // seconds between heartbeats; 3 missed: the instance is dead
  };
  Redis redis;
};

/// Reads a server config (JSON object, every key optional, unknown keys rejected) over the
/// defaults; throws Error naming the file and key.
ServerOptions load_server_options(const std::filesystem::path& path);

/// Like load_server_options, without validate() (for callers that override settings first).
ServerOptions read_server_options(const std::filesystem::path& path);

/// Checks ranges and the rule that a host other than loopback needs a key store (or `token`);
/// throws Error naming the setting.
void validate(const ServerOptions& options);

/// True for 127.0.0.0/8, ::1 and "localhost".
bool is_loopback_host(const std::string& host);

}  // namespace facecast::server
