// facecast.v1 message parsing, the binary header, errors, and the server config.
#include <catch2/catch.hpp>
#include <cmath>

#include "facecast/core/config.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/server/options.hpp"
#include "facecast/server/protocol.hpp"
#include "test_data.hpp"

using namespace facecast;
using namespace facecast::server;

namespace {

ProtocolLimits limits() {
  return {};
}

// The message of the Error that parsing `text` throws ("" if it does not throw).
std::string parse_error(const std::string& text, std::string* id = nullptr) {
  try {
    (void)parse_client_message(text, limits(), id);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("speak parses with defaults per output and audio", "[protocol]") {
  auto m = parse_client_message(R"({"type":"speak","id":"u1","text":"你好, hello"})", limits());
  const auto& s = std::get<SpeakRequest>(m);
  CHECK(s.id == "u1");
  CHECK(*s.text == "你好, hello");
  CHECK(s.output == Output::kWeights);
  CHECK(s.fps == 60);
  CHECK(s.audio);
  CHECK(s.timing == viseme::Timing::kTts);
  CHECK(s.rig.empty());

  m = parse_client_message(
      R"({"type":"speak","id":"u2","text":"hi","output":"frames","audio":false,"size":[320,240],"rig":"r1","lang":"en","voice":"en-gb","rate":5,"idle":false})",
      limits());
  const auto& f = std::get<SpeakRequest>(m);
  CHECK(f.output == Output::kFrames);
  CHECK(f.fps == 30);
  CHECK(!f.audio);
  CHECK(f.timing == viseme::Timing::kModel);
  CHECK(f.width == 320);
  CHECK(f.height == 240);
  CHECK(f.rig == "r1");
  CHECK(f.lang == viseme::LangMode::kEn);
  CHECK(f.voice == "en-gb");
  CHECK(f.rate == 5);
  CHECK(!f.idle);

  // Timestamps: no audio, JSON data given inline is serialized for the importer.
  m = parse_client_message(
      R"({"type":"speak","id":"t","timestamps":{"format":"json","data":[{"phone":"a","start":0,"end":0.2}]}})",
      limits());
  const auto& t = std::get<SpeakRequest>(m);
  REQUIRE(t.timestamps);
  CHECK(t.timestamps->format == viseme::TimestampFormat::kJson);
  CHECK(t.timestamps->data.find("\"phone\"") != std::string::npos);
  CHECK(!t.audio);
}

TEST_CASE("cancel and ping parse", "[protocol]") {
  CHECK(
      std::get<CancelRequest>(parse_client_message(R"({"type":"cancel","id":"x"})", limits())).id ==
      "x");
  const auto p =
      std::get<PingRequest>(parse_client_message(R"({"type":"ping","t":12.5})", limits()));
  CHECK(p.t == 12.5);
  CHECK(std::get<PingRequest>(parse_client_message(R"({"type":"ping"})", limits())).t.is_null());
}

TEST_CASE("bad messages are refused with the field named", "[protocol]") {
  CHECK_THAT(parse_error("not json"), Catch::Contains("malformed JSON"));
  CHECK_THAT(parse_error("[1,2]"), Catch::Contains("expected a JSON object"));
  CHECK_THAT(parse_error(R"({"id":"x"})"), Catch::Contains("type: missing"));
  CHECK_THAT(parse_error(R"({"type":"dance"})"), Catch::Contains("unknown message type 'dance'"));
  CHECK_THAT(parse_error(R"({"type":"speak","text":"hi"})"), Catch::Contains("id: missing"));
  CHECK_THAT(parse_error(R"({"type":"speak","id":"","text":"hi"})"), Catch::Contains("id:"));
  CHECK_THAT(parse_error(R"({"type":"speak","id":"a","text":5})"),
             Catch::Contains("text: expected a string"));
  CHECK_THAT(parse_error(R"({"type":"speak","id":"a"})"),
             Catch::Contains("exactly one of text and timestamps"));
  CHECK_THAT(parse_error(R"({"type":"speak","id":"a","text":"x","fps":500})"),
             Catch::Contains("fps: 500 is outside"));
  CHECK_THAT(parse_error(R"({"type":"speak","id":"a","text":"x","output":"video"})"),
             Catch::Contains("output: 'video'"));
  CHECK_THAT(parse_error(R"({"type":"speak","id":"a","text":"x","size":[8,8]})"),
             Catch::Contains("size[0]"));
  CHECK_THAT(parse_error(R"({"type":"speak","id":"a","text":"x","lang":"fr"})"),
             Catch::Contains("fr"));
  CHECK_THAT(parse_error(R"({"type":"speak","id":"a","text":"x","ouput":"frames"})"),
             Catch::Contains("unknown field 'ouput'"));
  CHECK_THAT(parse_error(R"({"type":"speak","id":"a","text":"x","rig":"../etc"})"),
             Catch::Contains("rig:"));
  CHECK_THAT(parse_error(R"({"type":"speak","id":"a","text":"x","audio":"yes"})"),
             Catch::Contains("audio: expected true or false"));
  CHECK_THAT(
      parse_error(
          R"({"type":"speak","id":"a","timestamps":{"format":"json","data":"[]"},"audio":true})"),
      Catch::Contains("audio: not available with timestamps"));
  CHECK_THAT(parse_error(R"({"type":"speak","id":"a","timestamps":{"format":"mp3","data":""}})"),
             Catch::Contains("mp3"));
  CHECK_THAT(parse_error(R"({"type":"cancel"})"), Catch::Contains("id: missing"));
  CHECK_THAT(parse_error(R"({"type":"ping","x":1})"), Catch::Contains("unknown field 'x'"));
  CHECK_THAT(parse_error(R"({"type":"ping","t":1e99999})"), Catch::Contains("malformed JSON"));
  CHECK_THAT(parse_error(std::string(40, '[') + std::string(40, ']')),
             Catch::Contains("JSON nests deeper than 32 levels"));
  // The id is known as soon as it is parsed, so the error can name it.
  std::string id;
  (void)parse_error(R"({"type":"speak","id":"u9","text":7})", &id);
  CHECK(id == "u9");
}

TEST_CASE("text length is limited in characters, not bytes", "[protocol]") {
  ProtocolLimits l;
  l.max_text = 4;
  CHECK_NOTHROW(parse_client_message(R"({"type":"speak","id":"a","text":"你好你好"})", l));
  try {
    (void)parse_client_message(R"({"type":"speak","id":"a","text":"你好你好你"})", l);
    FAIL("no error");
  } catch (...) {
    const Problem p = describe(std::current_exception());
    CHECK(p.code == Code::kLimit);
    CHECK_THAT(p.message, Catch::Contains("5 characters, the limit is 4"));
  }
}

TEST_CASE("describe maps every exception to one protocol error", "[protocol]") {
  const auto of = [](auto&& thrower) {
    try {
      thrower();
    } catch (...) {
      return describe(std::current_exception());
    }
    return Problem{};
  };
  auto p = of([] { throw Error("rig 'x' does not exist", ErrorCode::kNotFound); });
  CHECK(p.code == Code::kNotFound);
  CHECK(p.status == 404);
  p = of([] { throw RequestError(Code::kRateLimited, "slow down"); });
  CHECK(p.code == Code::kRateLimited);
  CHECK(p.status == 429);
  p = of([] { throw std::logic_error("bug"); });
  CHECK(p.code == Code::kInternal);
  CHECK(p.status == 500);
  const auto msg = nlohmann::json::parse(error_message(std::string("u1"), p));
  CHECK(msg["type"] == "error");
  CHECK(msg["id"] == "u1");
  CHECK(msg["code"] == "internal");
  CHECK(nlohmann::json::parse(error_message(std::nullopt, p))["id"].is_null());
}

TEST_CASE("binary header is 24 little-endian bytes", "[protocol]") {
  const float w[6] = {0, 0.5f, 1, 0.25f, 0.125f, 1};
  const std::string m = weights_message(7, 120, 60.0, 2, w, 6);
  REQUIRE(m.size() == kHeaderSize + 24);
  CHECK(static_cast<unsigned char>(m[0]) == 1);
  CHECK(static_cast<unsigned char>(m[1]) == 1);
  CHECK(m[2] == 0);
  CHECK(m[3] == 0);
  CHECK(static_cast<unsigned char>(m[4]) == 7);  // stream, little-endian
  CHECK(static_cast<unsigned char>(m[8]) == 120);
  CHECK(static_cast<unsigned char>(m[12]) == 2);
  const MediaHeader h = read_header(m);
  CHECK(h.kind == MediaKind::kWeights);
  CHECK(h.stream == 7);
  CHECK(h.first == 120);
  CHECK(h.count == 2);
  CHECK(h.pts == 2.0);
  CHECK(read_floats(std::string_view(m).substr(kHeaderSize)) == std::vector<float>(w, w + 6));

  const std::int16_t pcm[3] = {-2, 0, 32767};
  const std::string a = audio_message(3, 22050, 22050, pcm, 3);
  const MediaHeader ha = read_header(a);
  CHECK(ha.kind == MediaKind::kAudio);
  CHECK(ha.pts == 1.0);
  CHECK(static_cast<unsigned char>(a[kHeaderSize]) == 0xFE);
  CHECK(static_cast<unsigned char>(a[kHeaderSize + 1]) == 0xFF);

  const std::string j = jpeg_message(3, 15, 30.0, "\xFF\xD8\xFF\xD9");
  CHECK(read_header(j).pts == 0.5);
  CHECK(j.substr(kHeaderSize) == "\xFF\xD8\xFF\xD9");
  CHECK_THROWS_AS(read_header("short"), Error);
  std::string bad = j;
  bad[0] = 9;
  CHECK_THROWS_AS(read_header(bad), Error);
}

TEST_CASE("WebSocket frame headers of server messages follow RFC 6455", "[protocol]") {
  // Decoded the way a client does (5.2): FIN, opcode, no mask, 7-bit / 16-bit / 64-bit length.
  for (const bool text : {true, false}) {
    for (const std::size_t size :
         {std::size_t{0}, std::size_t{125}, std::size_t{126}, std::size_t{8830}, std::size_t{65535},
          std::size_t{65536}, std::size_t{0x123456789A}}) {
      std::array<std::uint8_t, 10> h{};
      const std::size_t n = frame_header(h, text, size);
      CAPTURE(text, size);
      CHECK((h[0] & 0x80) != 0);  // final
      CHECK((h[0] & 0x70) == 0);  // no extension bits
      CHECK((h[0] & 0x0F) == (text ? 1 : 2));
      CHECK((h[1] & 0x80) == 0);  // servers do not mask
      std::uint64_t length = h[1] & 0x7F;
      std::size_t expected = 2;
      if (length == 126) expected = 4;
      if (length == 127) expected = 10;
      REQUIRE(n == expected);
      if (n > 2) {
        length = 0;
        for (std::size_t i = 2; i < n; ++i) length = length << 8 | h[i];
      }
      CHECK(length == size);
      CHECK(n == (size < 126 ? 2u : size <= 65535 ? 4u : 10u));  // the shortest form
    }
  }
}

TEST_CASE("server options defaults mirror configs/server.json", "[protocol][config]") {
  const ServerOptions file = load_server_options(config_path("server.json"));
  const ServerOptions d;
  CHECK(file.host == d.host);
  CHECK(file.port == d.port);
  CHECK(file.data == d.data);
  CHECK(file.token == d.token);
  CHECK(file.web_root == d.web_root);
  CHECK(file.three_root == d.three_root);
  CHECK(file.three_vrm_root == d.three_vrm_root);
  CHECK(file.client_root == d.client_root);
  CHECK(file.default_rig == d.default_rig);
  CHECK(file.pose.kind == d.pose.kind);
  CHECK(file.io_threads == d.io_threads);
  CHECK(file.workers == d.workers);
  CHECK(file.job_workers == d.job_workers);
  CHECK(file.max_connections == d.max_connections);
  CHECK(file.max_message == d.max_message);
  CHECK(file.max_text == d.max_text);
  CHECK(file.max_body == d.max_body);
  CHECK(file.max_upload == d.max_upload);
  CHECK(file.speak_per_minute == d.speak_per_minute);
  CHECK(file.speak_burst == d.speak_burst);
  CHECK(file.max_queued_speaks == d.max_queued_speaks);
  CHECK(file.max_fps == d.max_fps);
  CHECK(file.max_frame_side == d.max_frame_side);
  CHECK(file.max_jobs == d.max_jobs);
  CHECK(file.max_render_seconds == d.max_render_seconds);
  CHECK(file.job_retention == d.job_retention);
  CHECK(file.max_json_depth == d.max_json_depth);
  CHECK(file.max_utterance_seconds == d.max_utterance_seconds);
  CHECK(file.max_piece == d.max_piece);
  CHECK(file.messages_per_second == d.messages_per_second);
  CHECK(file.message_burst == d.message_burst);
  CHECK(file.max_control_bytes == d.max_control_bytes);
  CHECK(file.max_connections_per_address == d.max_connections_per_address);
  CHECK(file.max_body_memory == d.max_body_memory);
  CHECK(file.live_audio_ahead == d.live_audio_ahead);
  CHECK(file.trusted_proxies == d.trusted_proxies);
  CHECK(file.max_audio_seconds == d.max_audio_seconds);
  CHECK(file.audio_decode_timeout == d.audio_decode_timeout);
  CHECK(file.lead == d.lead);
  CHECK(file.min_tick == d.min_tick);
  CHECK(file.channel_tick == d.channel_tick);
  CHECK(file.audio_chunk == d.audio_chunk);
  CHECK(file.cancel_fade == d.cancel_fade);
  CHECK(file.write_queue == d.write_queue);
  CHECK(file.slow_client_grace == d.slow_client_grace);
  CHECK(file.close_timeout == d.close_timeout);
  CHECK(file.frames_in_flight == d.frames_in_flight);
  CHECK(file.jpeg_quality == d.jpeg_quality);
  CHECK(file.render_contexts == d.render_contexts);
  CHECK(file.max_renderers == d.max_renderers);
  CHECK(file.send_buffer == d.send_buffer);
  CHECK(file.http_timeout == d.http_timeout);
  CHECK(file.ws_handshake_timeout == d.ws_handshake_timeout);
  CHECK(file.ws_idle_timeout == d.ws_idle_timeout);
  CHECK(file.shared_dir == d.shared_dir);
  CHECK(file.redis.url == d.redis.url);
  CHECK(file.redis.prefix == d.redis.prefix);
  CHECK(file.redis.heartbeat == d.redis.heartbeat);
  CHECK(file.shutdown_timeout == d.shutdown_timeout);
  CHECK(file.allowed_origins == d.allowed_origins);
  CHECK(file.log_level == d.log_level);
  CHECK(file.channels.empty());
  CHECK(file.presence_interval == d.presence_interval);
  CHECK(file.channel_idle == d.channel_idle);
  CHECK(file.drain_timeout == d.drain_timeout);
  const facecast::rig::DecodeLimits& fd = file.decode;
  const facecast::rig::DecodeLimits& dd = d.decode;
  CHECK(fd.max_json_depth == dd.max_json_depth);
  CHECK(fd.max_json_values == dd.max_json_values);
  CHECK(fd.max_decoded_bytes == dd.max_decoded_bytes);
  CHECK(fd.max_decoded_ratio == dd.max_decoded_ratio);
  CHECK(fd.max_image_side == dd.max_image_side);
  CHECK(fd.max_image_bytes == dd.max_image_bytes);
  CHECK(fd.max_texture_bytes == dd.max_texture_bytes);
  CHECK(fd.max_nodes == dd.max_nodes);
  CHECK(fd.max_meshes == dd.max_meshes);
  CHECK(fd.max_primitives == dd.max_primitives);
  CHECK(fd.max_morph_targets == dd.max_morph_targets);
  CHECK(fd.max_joints == dd.max_joints);
  CHECK(fd.max_accessors == dd.max_accessors);
  CHECK(fd.max_images == dd.max_images);
  CHECK(fd.max_obj_line == dd.max_obj_line);
  CHECK(fd.max_obj_face == dd.max_obj_face);
  // Every key of the file is one the loader knows (it rejects unknown keys), and every setting is
  // in the file: a key per field above.
  const auto j = load_json(config_path("server.json"));
  CHECK(file.keys == d.keys);
  CHECK(file.token_max_ttl == d.token_max_ttl);
  CHECK(file.allowed_hosts == d.allowed_hosts);
  CHECK(file.cors_origins == d.cors_origins);
  CHECK(file.vmc_targets.empty());
  CHECK(file.tenant_disk_quota == d.tenant_disk_quota);
  CHECK(file.rig_retention == d.rig_retention);
  CHECK(j.size() == 72);            // 71 settings + "_doc"
  CHECK(j["decode"].size() == 16);  // every field of rig::DecodeLimits
}

TEST_CASE("server config errors name the key", "[protocol][config]") {
  const auto dir = test::scratch_dir() / "config";
  std::filesystem::create_directories(dir);
  const auto load_error = [&](const std::string& text) -> std::string {
    write_file_atomic(dir / "s.json", text);
    try {
      (void)load_server_options(dir / "s.json");
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  CHECK_THAT(load_error(R"({"prot": 1})"), Catch::Contains("unknown key 'prot'"));
  CHECK_THAT(load_error(R"({"channels": {"show": {}}})"), Catch::Contains("producer_token"));
  CHECK_THAT(load_error(R"({"channels": {"show": {"producer_token": "short"}}})"),
             Catch::Contains("at least 8"));
  CHECK_THAT(load_error(R"({"channels": {"a b": {"producer_token": "long-enough"}}})"),
             Catch::Contains("not allowed"));
  CHECK_THAT(load_error(R"({"port": "x"})"), Catch::Contains("port: expected an integer"));
  CHECK_THAT(load_error(R"({"port": 70000})"), Catch::Contains("port"));
  CHECK_THAT(load_error(R"({"lead": -1})"), Catch::Contains("lead"));
  CHECK_THAT(load_error(R"({"log_level": "loud"})"), Catch::Contains("log_level"));
  CHECK_THAT(load_error(R"({"max_audio_seconds": 0})"), Catch::Contains("max_audio_seconds"));
  CHECK_THAT(load_error(R"({"audio_decode_timeout": 601})"),
             Catch::Contains("audio_decode_timeout"));
  CHECK_THAT(load_error(R"({"redis": {"url": "http://x"}})"), Catch::Contains("redis.url"));
  CHECK_THAT(load_error(R"({"redis": {"heartbeat": 0}})"), Catch::Contains("redis.heartbeat"));
  CHECK_THAT(load_error(R"({"decode": {"max_json_depth": 2}})"),
             Catch::Contains("decode.max_json_depth"));
  CHECK_THAT(load_error(R"({"decode": {"max_image_sides": 2}})"),
             Catch::Contains("unknown key 'decode.max_image_sides'"));
  CHECK_THAT(load_error(R"({"redis": {"hosts": 1}})"), Catch::Contains("hosts"));
  CHECK_THAT(load_error(R"({"pose": "sit"})"),
             Catch::Contains("s.json: pose") && Catch::Contains("sit"));
  CHECK_THAT(load_error(R"({"pose": "/nonexistent/wave.json"})"), Catch::Contains("wave.json"));
  write_file_atomic(dir / "wave.json", R"({"leftUpperArm": {"euler_deg": [0, 0, 30]}})");
  write_file_atomic(dir / "posed.json", R"({"pose": ")" + (dir / "wave.json").string() + R"("})");
  const ServerOptions posed = load_server_options(dir / "posed.json");
  CHECK(posed.pose.kind == rig::Pose::Kind::kFile);
  CHECK(posed.pose.bones.size() == 1);
  CHECK_THAT(load_error(R"({"host": "0.0.0.0"})"), Catch::Contains("set a token"));
  CHECK(load_error(R"({"host": "0.0.0.0", "token": "t0k3n"})").empty());
  CHECK(is_loopback_host("127.0.0.1"));
  CHECK(is_loopback_host("127.3.2.1"));
  CHECK(is_loopback_host("::1"));
  CHECK(is_loopback_host("localhost"));
  CHECK(!is_loopback_host("0.0.0.0"));
  CHECK(!is_loopback_host("192.168.1.4"));
}
