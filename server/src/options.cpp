#include "facecast/server/options.hpp"

#include <algorithm>
#include <boost/asio/ip/address.hpp>
#include <cctype>

#include "facecast/core/config_reader.hpp"
#include "facecast/core/error.hpp"
#include "facecast/server/keys.hpp"
#include "facecast/server/protocol.hpp"
#include "facecast/server/vmc.hpp"

namespace facecast::server {

bool is_loopback_host(const std::string& host) {
  if (host == "localhost") return true;
  boost::system::error_code ec;
  const auto addr = boost::asio::ip::make_address(host, ec);
  return !ec && addr.is_loopback();
}

namespace {

// channels.<name>.rtmp: {"url", "size": [w, h], "fps", "video_kbps", "audio_kbps", "delay"}.
void read_rtmp(ConfigReader& channel, ServerOptions::Rtmp& r) {
  ConfigReader& c = channel.section("rtmp");
  c.require("url", r.url);
  std::vector<int> size{r.width, r.height};
  c.read("size", size).read("fps", r.fps).read("video_kbps", r.video_kbps);
  c.read("audio_kbps", r.audio_kbps).read("delay", r.delay);
  if (size.size() != 2) c.fail("size", "expected [width, height]");
  r.width = size[0];
  r.height = size[1];
}

}  // namespace

ServerOptions load_server_options(const std::filesystem::path& path) {
  ServerOptions o = read_server_options(path);
  validate(o);
  return o;
}

ServerOptions read_server_options(const std::filesystem::path& path) {
  // Every key is optional (the defaults are ServerOptions'); a line per row of the table in
  // docs/server.md (Configuration).
  ServerOptions o;
  ConfigReader c = ConfigReader::open(path);
  c.read("host", o.host).read("port", o.port);
  c.read("data", o.data);
  c.read("token", o.token);
  if (c.has("keys")) {
    // false: "auto", true: "required", a string: the store's path ("auto" and "required" too).
    nlohmann::json keys;
    c.read("keys", keys);
    if (keys.is_boolean())
      o.keys = keys.get<bool>() ? "required" : "auto";
    else if (keys.is_string() && !keys.get<std::string>().empty())
      o.keys = keys.get<std::string>();
    else
      c.fail("keys", "expected true, false or the key store's path");
  }
  c.read("token_max_ttl", o.token_max_ttl);
  c.read("allowed_hosts", o.allowed_hosts).read("cors_origins", o.cors_origins);
  c.read("web_root", o.web_root).read("three_root", o.three_root);
  c.read("three_vrm_root", o.three_vrm_root).read("client_root", o.client_root);
  c.read("default_rig", o.default_rig);
  if (c.has("pose")) {
    std::string pose;
    c.read("pose", pose);
    o.pose = rig::parse_pose(pose, path.string() + ": pose");
  }
  c.read("io_threads", o.io_threads).read("workers", o.workers).read("job_workers", o.job_workers);
  c.read("max_connections", o.max_connections);
  c.read("max_message", o.max_message);
  c.read("max_text", o.max_text);
  c.read("max_body", o.max_body).read("max_upload", o.max_upload);
  c.read("speak_per_minute", o.speak_per_minute).read("speak_burst", o.speak_burst);
  c.read("max_queued_speaks", o.max_queued_speaks);
  c.read("max_fps", o.max_fps).read("max_frame_side", o.max_frame_side);
  c.read("max_jobs", o.max_jobs).read("max_render_seconds", o.max_render_seconds);
  c.read("job_retention", o.job_retention);
  c.read("tenant_disk_quota", o.tenant_disk_quota).read("rig_retention", o.rig_retention);
  c.read("max_json_depth", o.max_json_depth).read("max_utterance_seconds", o.max_utterance_seconds);
  c.read("max_piece", o.max_piece);
  c.read("messages_per_second", o.messages_per_second).read("message_burst", o.message_burst);
  c.read("max_control_bytes", o.max_control_bytes);
  c.read("max_connections_per_address", o.max_connections_per_address);
  c.read("max_body_memory", o.max_body_memory).read("trusted_proxies", o.trusted_proxies);
  c.read("live_audio_ahead", o.live_audio_ahead);
  c.read("max_audio_seconds", o.max_audio_seconds);
  c.read("audio_decode_timeout", o.audio_decode_timeout);
  c.read("lead", o.lead);
  c.read("min_tick", o.min_tick);
  c.read("channel_tick", o.channel_tick);
  c.read("audio_chunk", o.audio_chunk);
  c.read("cancel_fade", o.cancel_fade);
  c.read("write_queue", o.write_queue);
  c.read("slow_client_grace", o.slow_client_grace);
  c.read("close_timeout", o.close_timeout);
  c.read("frames_in_flight", o.frames_in_flight);
  c.read("jpeg_quality", o.jpeg_quality);
  c.read("render_contexts", o.render_contexts).read("max_renderers", o.max_renderers);
  c.read("send_buffer", o.send_buffer);
  c.read("http_timeout", o.http_timeout);
  c.read("ws_handshake_timeout", o.ws_handshake_timeout).read("ws_idle_timeout", o.ws_idle_timeout);
  c.read("shutdown_timeout", o.shutdown_timeout).read("drain_timeout", o.drain_timeout);
  c.read("allowed_origins", o.allowed_origins);
  c.read("log_level", o.log_level);
  c.read("presence_interval", o.presence_interval).read("channel_idle", o.channel_idle);
  nlohmann::json channels = nlohmann::json::object();
  c.read("channels", channels);
  if (!channels.is_object()) c.fail("channels", "expected an object {name: {producer_token}}");
  for (const auto& [name, v] : channels.items()) {
    ConfigReader ch(v, path.string() + ": channels." + name);
    ServerOptions::Channel channel;
    channel.name = name;
    ch.require("producer_token", channel.producer_token);
    ch.read("tenant", channel.tenant);
    if (ch.has("rtmp")) read_rtmp(ch, o.rtmp[name]);
    if (ch.has("vmc")) {
      ConfigReader& vmc = ch.section("vmc");
      channel.vmc.emplace();
      vmc.require("targets", channel.vmc->targets).read("names", channel.vmc->names);
    }
    ch.reject_unknown();  // also the rtmp section
    o.channels.push_back(std::move(channel));
  }
  nlohmann::json vmc_targets = nlohmann::json::object();
  c.read("vmc_targets", vmc_targets);
  if (!vmc_targets.is_object())
    c.fail("vmc_targets", "expected an object {name: {targets, names}}");
  for (const auto& [name, v] : vmc_targets.items()) {
    ConfigReader t(v, path.string() + ": vmc_targets." + name);
    auto& vmc = o.vmc_targets[name];
    t.require("targets", vmc.targets).read("names", vmc.names);
    t.reject_unknown();
  }
  if (c.has("decode")) {
    ConfigReader& d = c.section("decode");
    rig::DecodeLimits& l = o.decode;
    d.read("max_json_depth", l.max_json_depth).read("max_json_values", l.max_json_values);
    d.read("max_decoded_bytes", l.max_decoded_bytes).read("max_decoded_ratio", l.max_decoded_ratio);
    d.read("max_image_side", l.max_image_side).read("max_image_bytes", l.max_image_bytes);
    d.read("max_texture_bytes", l.max_texture_bytes);
    d.read("max_nodes", l.max_nodes).read("max_meshes", l.max_meshes);
    d.read("max_primitives", l.max_primitives).read("max_morph_targets", l.max_morph_targets);
    d.read("max_joints", l.max_joints).read("max_accessors", l.max_accessors);
    d.read("max_images", l.max_images);
    d.read("max_obj_line", l.max_obj_line).read("max_obj_face", l.max_obj_face);
  }
  c.read("shared_dir", o.shared_dir);
  if (c.has("redis")) {
    ConfigReader& r = c.section("redis");
    r.read("url", o.redis.url).read("prefix", o.redis.prefix).read("heartbeat", o.redis.heartbeat);
  }
  c.reject_unknown();
  return o;
}

void validate(const ServerOptions& o) {
  auto need = [](bool ok, const std::string& what) {
    if (!ok) throw Error(what);
  };
  need(!o.host.empty(), "host: empty");
  need(o.port >= 0 && o.port <= 65535, "port: must be in 0..65535");
  need(o.io_threads >= 1 && o.io_threads <= 64, "io_threads: must be in 1..64");
  need(o.workers >= 1 && o.workers <= 64, "workers: must be in 1..64");
  need(o.job_workers >= 1 && o.job_workers <= 16, "job_workers: must be in 1..16");
  need(o.max_connections >= 1, "max_connections: must be at least 1");
  need(o.max_message >= 256, "max_message: must be at least 256 bytes");
  need(o.max_text >= 1, "max_text: must be at least 1");
  need(o.max_body >= 256, "max_body: must be at least 256 bytes");
  need(o.max_upload >= 1024, "max_upload: must be at least 1024 bytes");
  need(o.speak_per_minute > 0, "speak_per_minute: must be positive");
  need(o.speak_burst >= 1, "speak_burst: must be at least 1");
  need(o.max_queued_speaks >= 1, "max_queued_speaks: must be at least 1");
  need(o.max_fps >= 1 && o.max_fps <= 1000, "max_fps: must be in 1..1000");
  need(o.max_frame_side >= 16 && o.max_frame_side <= 8192, "max_frame_side: must be in 16..8192");
  need(o.max_jobs >= 1, "max_jobs: must be at least 1");
  need(o.max_render_seconds > 0, "max_render_seconds: must be positive");
  need(o.job_retention >= 0, "job_retention: must not be negative (0 keeps jobs forever)");
  need(o.rig_retention >= 0, "rig_retention: must not be negative (0 keeps rigs forever)");
  need(o.max_json_depth >= 4 && o.max_json_depth <= 256, "max_json_depth: must be in 4..256");
  need(o.max_utterance_seconds >= 1 && o.max_utterance_seconds <= 86400,
       "max_utterance_seconds: must be in 1..86400");
  need(o.max_piece >= 16, "max_piece: must be at least 16 characters");
  need(o.messages_per_second > 0, "messages_per_second: must be positive");
  need(o.message_burst >= 1, "message_burst: must be at least 1");
  need(o.max_control_bytes >= 1024, "max_control_bytes: must be at least 1024 bytes");
  need(o.max_connections_per_address >= 1, "max_connections_per_address: must be at least 1");
  need(o.live_audio_ahead >= 0.5 && o.live_audio_ahead <= 600,
       "live_audio_ahead: must be in 0.5..600 seconds");
  need(o.max_body_memory >= o.max_upload,
       "max_body_memory: must be at least max_upload (one upload must fit)");
  for (const auto& p : o.trusted_proxies) {
    boost::system::error_code ec;
    boost::asio::ip::make_address(p, ec);
    need(!ec, "trusted_proxies: '" + p + "' is not an IP address");
  }
  need(o.max_audio_seconds > 0 && o.max_audio_seconds <= 3600,
       "max_audio_seconds: must be in (0, 3600]");
  need(o.audio_decode_timeout > 0 && o.audio_decode_timeout <= 600,
       "audio_decode_timeout: must be in (0, 600] seconds");
  need(o.lead >= 0 && o.lead <= 10, "lead: must be in 0..10 seconds");
  need(o.min_tick >= 0 && o.min_tick <= 1, "min_tick: must be in 0..1 seconds");
  need(o.channel_tick >= 0 && o.channel_tick <= 1, "channel_tick: must be in 0..1 seconds");
  need(o.audio_chunk >= 0.01 && o.audio_chunk <= 10, "audio_chunk: must be in 0.01..10 seconds");
  need(o.cancel_fade >= 0 && o.cancel_fade <= 5, "cancel_fade: must be in 0..5 seconds");
  need(o.write_queue >= 2, "write_queue: must be at least 2");
  need(o.slow_client_grace > 0, "slow_client_grace: must be positive");
  need(o.close_timeout > 0, "close_timeout: must be positive");
  need(o.frames_in_flight >= 1 && o.frames_in_flight <= 16, "frames_in_flight: must be in 1..16");
  need(o.jpeg_quality >= 1 && o.jpeg_quality <= 100, "jpeg_quality: must be in 1..100");
  need(o.render_contexts >= 1 && o.render_contexts <= 16, "render_contexts: must be in 1..16");
  need(o.max_renderers >= 1, "max_renderers: must be at least 1");
  need(o.send_buffer >= 0, "send_buffer: must not be negative");
  need(o.http_timeout > 0, "http_timeout: must be positive");
  need(o.ws_handshake_timeout > 0, "ws_handshake_timeout: must be positive");
  need(o.ws_idle_timeout > 0, "ws_idle_timeout: must be positive");
  need(o.shutdown_timeout > 0, "shutdown_timeout: must be positive");
  need(o.drain_timeout >= 0, "drain_timeout: must not be negative");
  need(o.log_level == "debug" || o.log_level == "info" || o.log_level == "warn" ||
           o.log_level == "error",
       "log_level: '" + o.log_level + "' is not debug, info, warn or error");
  need(!o.default_rig.empty(), "default_rig: empty");
  need(o.presence_interval > 0, "presence_interval: must be positive");
  need(o.channel_idle >= 0 && o.channel_idle <= 3600, "channel_idle: must be in 0..3600 seconds");
  const rig::DecodeLimits& d = o.decode;
  need(d.max_json_depth >= 16 && d.max_json_depth <= 10000,
       "decode.max_json_depth: must be in 16..10000");
  need(d.max_json_values >= 1024, "decode.max_json_values: must be at least 1024");
  need(d.max_decoded_bytes >= (1u << 20), "decode.max_decoded_bytes: must be at least 1 MiB");
  need(d.max_decoded_ratio >= 4, "decode.max_decoded_ratio: must be at least 4");
  need(d.max_image_side >= 16 && d.max_image_side <= 65535,
       "decode.max_image_side: must be in 16..65535");
  need(d.max_image_bytes >= 1024, "decode.max_image_bytes: must be at least 1024");
  need(d.max_texture_bytes >= d.max_image_bytes,
       "decode.max_texture_bytes: must be at least max_image_bytes");
  need(d.max_nodes >= 1 && d.max_meshes >= 1 && d.max_primitives >= 1 && d.max_joints >= 1 &&
           d.max_accessors >= 1 && d.max_images >= 1,
       "decode: max_nodes, max_meshes, max_primitives, max_joints, max_accessors and max_images "
       "must be at least 1");
  need(d.max_obj_line >= 256, "decode.max_obj_line: must be at least 256 bytes");
  need(d.max_obj_face >= 3, "decode.max_obj_face: must be at least 3");
  need(o.redis.url.empty() || o.redis.url.starts_with("redis://"),
       "redis.url: '" + o.redis.url + "' is not a redis:// address");
  need(o.redis.heartbeat >= 0.05 && o.redis.heartbeat <= 60,
       "redis.heartbeat: must be in 0.05..60 seconds");
  for (const auto& ch : o.channels) {
    check_channel_name(nlohmann::json(ch.name), "channels: name");
    need(ch.producer_token.size() >= 8,
         "channels." + ch.name + ".producer_token: must be at least 8 characters");
    check_tenant_name(ch.tenant, "channels." + ch.name + ".tenant");
    if (ch.vmc) {
      const std::string at = "channels." + ch.name + ".vmc.";
      need(!ch.vmc->targets.empty() && ch.vmc->targets.size() <= 16,
           at + "targets: 1 to 16 HOST:PORT entries");
      for (const auto& t : ch.vmc->targets) (void)parse_vmc_target(t, at + "targets");
      (void)parse_vmc_names(ch.vmc->names, at + "names");
    }
  }
  need(o.vmc_targets.size() <= 64, "vmc_targets: at most 64 names");
  for (const auto& [name, vmc] : o.vmc_targets) {
    const std::string at = "vmc_targets." + name + ".";
    need(!name.empty() && name.size() <= 64 &&
             std::all_of(name.begin(), name.end(),
                         [](char ch) {
                           return std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' ||
                                  ch == '-' || ch == '.';
                         }),
         "vmc_targets: '" + name + "' is not a name (letters, digits, _ - .)");
    need(!vmc.targets.empty() && vmc.targets.size() <= 16,
         at + "targets: 1 to 16 HOST:PORT entries");
    for (const auto& t : vmc.targets) (void)parse_vmc_target(t, at + "targets");
    (void)parse_vmc_names(vmc.names, at + "names");
  }
  for (const auto& entry : o.rtmp) {
    const std::string& name = entry.first;  // not a structured binding: the lambda captures it
    const ServerOptions::Rtmp& r = entry.second;
    const std::string at = "channels." + name + ".rtmp.";
    need(std::any_of(o.channels.begin(), o.channels.end(),
                     [&](const auto& ch) { return ch.name == name; }),
         at + "url: there is no channel '" + name + "'");
    need(r.url.starts_with("rtmp://") || r.url.starts_with("rtmps://"),
         at + "url: '" + r.url + "' is not an rtmp:// or rtmps:// address");
    need(r.width >= 16 && r.height >= 16 && r.width <= o.max_frame_side &&
             r.height <= o.max_frame_side && r.width % 2 == 0 && r.height % 2 == 0,
         at + "size: even numbers in 16..max_frame_side");
    need(r.fps >= 1 && r.fps <= 60, at + "fps: must be in 1..60");
    need(r.video_kbps >= 100 && r.audio_kbps >= 16, at + "video_kbps >= 100, audio_kbps >= 16");
    need(r.delay >= 0.1 && r.delay <= 10, at + "delay: must be in 0.1..10 seconds");
  }
  need(o.token_max_ttl >= 10 && o.token_max_ttl <= 86400, "token_max_ttl: must be in 10..86400");
  for (const auto& h : o.allowed_hosts)
    need(!h.empty() && h.find_first_of("/ \t") == std::string::npos,
         "allowed_hosts: '" + h + "' is not a host name");
  for (const auto& origin : o.cors_origins)
    need(origin.starts_with("http://") || origin.starts_with("https://"),
         "cors_origins: '" + origin + "' is not an origin (https://name[:port])");
  // Off loopback nobody may get in without a key: a key store (or the old single token).
  std::error_code ec;
  if (!is_loopback_host(o.host) && o.token.empty() && o.keys == "auto" &&
      !std::filesystem::exists(key_store_path(o), ec)) {
    throw Error("host " + o.host + " is not a loopback address and there is no key store (" +
                key_store_path(o).string() +
                "): create a key with `facecast keys create --tenant " +
                "NAME --scopes admin --data " + o.data.string() +
                "` (or set a token, the single admin key: --token or FACECAST_TOKEN)");
  }
}

}  // namespace facecast::server
