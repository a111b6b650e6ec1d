// Live audio in (docs/protocol.md, "Live audio in"): PCM16 chunks as binary messages of kind 4
// open a weights stream, the chunk flagged last ends it with every frame up to the audio's end;
// bad chunks get an error and the connection and stream stay open.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

#include "client.hpp"
#include "facecast/viseme/analyze.hpp"
#include "facecast/viseme/audio.hpp"

using namespace fctest;

namespace {

std::string chunk(int rate, std::uint32_t first, const std::int16_t* pcm, std::uint32_t count,
                  bool last, std::uint8_t kind = 4) {
  std::string b(24 + 2 * static_cast<std::size_t>(count), '\0');
  b[0] = static_cast<char>(kind), b[1] = 1, b[2] = last ? 1 : 0;
  const auto put = [&](std::size_t at, std::uint32_t v) {
    for (int k = 0; k < 4; ++k)
      b[at + static_cast<std::size_t>(k)] = static_cast<char>(v >> (8 * k));
  };
  put(4, static_cast<std::uint32_t>(rate));
  put(8, first);
  put(12, count);
  for (std::uint32_t i = 0; i < count; ++i) {
    const auto v = static_cast<std::uint16_t>(pcm[i]);
    b[24 + 2 * i] = static_cast<char>(v & 0xff);
    b[25 + 2 * i] = static_cast<char>(v >> 8);
  }
  return b;
}

// A live audio stream's answer up to its stream_end: one shape's track over the frames (the
// shape's index found in stream_start) and the error messages on the way.
struct LiveStream {
  nlohmann::json start, end;
  std::vector<float> track;
  std::vector<std::string> errors;
};
LiveStream read_live_stream(WsClient& c, const std::string& shape) {
  LiveStream out;
  std::size_t names = 0, index = 0;
  while (out.end.is_null()) {
    const auto m = c.read(30);
    REQUIRE(m);
    if (m->text) {
      const auto j = m->json();
      if (j["type"] == "stream_start") {
        out.start = j;
        names = j["names"].size() + j["extra"].size();
        const auto& list = j["names"];
        index = static_cast<std::size_t>(std::find(list.begin(), list.end(), shape) - list.begin());
        REQUIRE(index < list.size());
      }
      if (j["type"] == "error") out.errors.push_back(j["message"]);
      if (j["type"] == "stream_end") out.end = j;
      continue;
    }
    const auto h = facecast::server::read_header(m->data);
    const auto values = facecast::server::read_floats(std::string_view(m->data).substr(24));
    for (std::uint32_t k = 0; k < h.count; ++k) out.track.push_back(values[k * names + index]);
  }
  return out;
}

}  // namespace

TEST_CASE("live audio chunks stream weights back and end with stream_end", "[ws][audio]") {
  facecast::viseme::Options o;
  o.timing = facecast::viseme::Timing::kTts;
  const auto u = facecast::viseme::analyze("Open the big window, please", o);
  const int rate = u.sample_rate;  // espeak-ng's 22050 Hz: the server resamples
  TestServer s;
  WsClient c(s.port());
  REQUIRE(c.read_json(10)["type"] == "hello");
  // Bad first: no stream open, a wrong kind, a short message.
  c.send_binary(chunk(rate, 5, u.pcm.data(), 10, false));
  CHECK(c.read_json(10)["code"] == "invalid_input");
  c.send_binary(chunk(rate, 0, u.pcm.data(), 10, false, 9));
  CHECK(c.read_json(10)["message"].get<std::string>().find("kind 9") != std::string::npos);
  c.send_binary("xx");
  CHECK(c.read_json(10)["code"] == "invalid_input");
  const std::uint32_t n = 441;  // 20 ms
  std::uint32_t at = 0;
  for (; at + n < u.pcm.size(); at += n) {
    c.send_binary(chunk(rate, at, u.pcm.data() + at, n, false));
    if (at == 10 * n) c.send_binary(chunk(rate, at, u.pcm.data(), n, false));  // not following on
  }
  c.send_binary(
      chunk(rate, at, u.pcm.data() + at, static_cast<std::uint32_t>(u.pcm.size() - at), true));
  nlohmann::json start, end, error;
  std::vector<float> jaw;
  std::uint32_t expected_first = 0;
  std::size_t names = 0, jaw_index = 0;
  while (end.is_null()) {
    const auto m = c.read(30);
    REQUIRE(m);
    if (m->text) {
      const auto j = m->json();
      if (j["type"] == "stream_start") {
        start = j;
        names = j["names"].size() + j["extra"].size();
        const auto& list = j["names"];
        jaw_index =
            static_cast<std::size_t>(std::find(list.begin(), list.end(), "jawOpen") - list.begin());
      }
      if (j["type"] == "stream_end") end = j;
      if (j["type"] == "error") error = j;
      continue;
    }
    const auto h = facecast::server::read_header(m->data);
    CHECK(h.first == expected_first);
    CHECK(std::abs(h.pts - h.first / 60.0) < 1e-9);
    expected_first = h.first + h.count;
    const auto values = facecast::server::read_floats(std::string_view(m->data).substr(24));
    REQUIRE(values.size() == h.count * names);
    for (std::uint32_t k = 0; k < h.count; ++k) jaw.push_back(values[k * names + jaw_index]);
  }
  CHECK(start["id"] == "audio-" + std::to_string(start["stream"].get<int>()));
  CHECK(start["fps"] == 60);
  CHECK(start["frames"].is_null());
  REQUIRE(!error.is_null());
  CHECK(error["message"].get<std::string>().find("follow on") != std::string::npos);
  const double seconds = static_cast<double>(u.pcm.size()) / rate;
  CHECK(end["frames"] == static_cast<int>(std::floor(seconds * 60)) + 1);
  CHECK(jaw.size() == end["frames"].get<std::size_t>());
  // The mouth opens on the vowels and is closed at the start (leading silence).
  CHECK(*std::max_element(jaw.begin(), jaw.end()) > 0.2f);
  CHECK(jaw.front() < 0.05f);
  // The connection still works.
  c.send(nlohmann::json{{"type", "ping"}, {"t", 1}});
  CHECK(c.read_json(10)["type"] == "pong");
}

TEST_CASE("expression tags over live audio start at the next frame", "[ws][audio]") {
  facecast::viseme::Options o;
  o.timing = facecast::viseme::Timing::kTts;
  const auto u = facecast::viseme::analyze("Open the big window, please", o);
  const int rate = u.sample_rate;
  TestServer s;
  WsClient c(s.port());
  REQUIRE(c.read_json(10)["type"] == "hello");
  c.send(nlohmann::json{{"type", "expression"}, {"tags", "(surprise,63,0.1)"}});
  auto e = c.read_json(10);
  CHECK(e["message"].get<std::string>().find("no live audio stream") != std::string::npos);
  const std::uint32_t n = 441, half = static_cast<std::uint32_t>(u.pcm.size() / 2);
  std::uint32_t at = 0;
  for (; at < half; at += n) c.send_binary(chunk(rate, at, u.pcm.data() + at, n, false));
  c.send(nlohmann::json{{"type", "expression"}, {"tags", "(surprise,99,0.1)"}});  // out of range
  c.send(nlohmann::json{{"type", "expression"}, {"tags", "(surprise,63,0.1)"}});
  c.send_binary(
      chunk(rate, at, u.pcm.data() + at, static_cast<std::uint32_t>(u.pcm.size() - at), true));
  const LiveStream r = read_live_stream(c, "browInnerUp");
  const std::vector<float>& brow = r.track;
  const std::vector<std::string>& errors = r.errors;
  REQUIRE(errors.size() == 1);
  CHECK(errors[0].find("intensity 0..63") != std::string::npos);
  // The brows stay down until the tag arrived (about half the audio), then rise and hold.
  REQUIRE(brow.size() > 60);
  const std::size_t before = static_cast<std::size_t>(0.3 * static_cast<double>(brow.size()));
  CHECK(*std::max_element(brow.begin(), brow.begin() + static_cast<long>(before)) < 0.02f);
  CHECK(brow.back() > 0.5f);
}

TEST_CASE("an aligned live audio stream takes its text beside the audio", "[ws][audio][stream]") {
  // Speech with its words' onsets: each word's text is sent as its audio starts (a streaming TTS).
  facecast::viseme::Options o;
  o.timing = facecast::viseme::Timing::kTts;
  const auto u = facecast::viseme::analyze("Bring me the maps before the rain begins", o);
  const int rate = u.sample_rate;
  TestServer s;
  WsClient c(s.port());
  REQUIRE(c.read_json(10)["type"] == "hello");
  c.send(nlohmann::json{{"type", "audio_text"}, {"text", "hello "}});
  CHECK(c.read_json(10)["message"].get<std::string>().find("no live audio stream") !=
        std::string::npos);
  const std::uint32_t n = 2205;  // 100 ms
  std::size_t word = 0;
  std::uint32_t at = 0;
  for (; at < u.pcm.size(); at += n) {
    const auto count = std::min<std::uint32_t>(n, static_cast<std::uint32_t>(u.pcm.size() - at));
    const bool last = at + count >= u.pcm.size();
    std::string b = chunk(rate, at, u.pcm.data() + at, count, false);
    if (at == 0) b[2] = static_cast<char>(b[2] | 2);  // aligned
    c.send_binary(b);
    for (; word < u.words.size() && u.words[word].start * rate < at + count; ++word)
      c.send(nlohmann::json{{"type", "audio_text"},
                            {"text", u.words[word].text + " "},
                            {"final", word + 1 == u.words.size()}});
    if (last) c.send_binary(chunk(rate, at + count, u.pcm.data(), 0, true));
  }
  const LiveStream r = read_live_stream(c, "jawOpen");
  const std::vector<float>& jaw = r.track;
  const std::vector<std::string>& errors = r.errors;
  const nlohmann::json& end = r.end;
  for (const auto& e : errors) WARN(e);
  CHECK(errors.empty());
  const double seconds = static_cast<double>(u.pcm.size()) / rate;
  CHECK(end["frames"] == static_cast<int>(std::floor(seconds * 60)) + 1);
  REQUIRE(jaw.size() == end["frames"].get<std::size_t>());
  // The face speaks: the jaw opens on the vowels (the frame-level agreement with the whole-file
  // alignment is tests/viseme/test_align_stream.cpp's).
  CHECK(*std::max_element(jaw.begin(), jaw.end()) > 0.1f);
  CHECK(jaw.back() < 0.05f);
  // Text on a stream that is not aligned, and text that is not English, are refused.
  std::vector<std::int16_t> quiet(441, 0);
  c.send_binary(chunk(rate, 0, quiet.data(), 441, false));
  c.send(nlohmann::json{{"type", "audio_text"}, {"text", "hello "}});
  std::string got;
  for (int k = 0; k < 5 && got.empty(); ++k) {
    const auto j = c.read_json(10);
    if (j["type"] == "error") got = j["message"];
  }
  CHECK(got.find("not aligned") != std::string::npos);
}

TEST_CASE("an aligned live audio stream takes text with its times, in Chinese too",
          "[ws][audio][stream]") {
  // Each syllable with its time beside the audio, as TTS services stream their alignment.
  facecast::viseme::Options o;
  o.timing = facecast::viseme::Timing::kTts;
  const auto u = facecast::viseme::analyze("今天我们聊一聊新的功能", o);
  const int rate = u.sample_rate;
  TestServer s;
  WsClient c(s.port());
  REQUIRE(c.read_json(10)["type"] == "hello");
  const std::uint32_t n = 2205;  // 100 ms
  std::size_t next = 0;
  for (std::uint32_t at = 0; at < u.pcm.size(); at += n) {
    const auto count = std::min<std::uint32_t>(n, static_cast<std::uint32_t>(u.pcm.size() - at));
    std::string b = chunk(rate, at, u.pcm.data() + at, count, false);
    if (at == 0) {
      b[2] = static_cast<char>(b[2] | 2);  // aligned
      c.send_binary(b);
      c.send(nlohmann::json{{"type", "audio_text"}, {"text", "今"}, {"start", 0.1}});
    } else {
      c.send_binary(b);
    }
    for (; next < u.syllables.size() && u.syllables[next].start * rate < at + count; ++next)
      c.send(nlohmann::json{{"type", "audio_text"},
                            {"text", u.syllables[next].text},
                            {"start", u.syllables[next].start},
                            {"end", u.syllables[next].end},
                            {"final", next + 1 == u.syllables.size()}});
  }
  c.send_binary(chunk(rate, static_cast<std::uint32_t>(u.pcm.size()), u.pcm.data(), 0, true));
  const LiveStream r = read_live_stream(c, "jawOpen");
  const std::vector<float>& jaw = r.track;
  const std::vector<std::string>& errors = r.errors;
  // Only the message with a start and no end was refused.
  REQUIRE(errors.size() == 1);
  CHECK(errors[0].find("start and end come together") != std::string::npos);
  CHECK(jaw.size() ==
        static_cast<std::size_t>(std::floor(static_cast<double>(u.pcm.size()) / rate * 60)) + 1);
  CHECK(*std::max_element(jaw.begin(), jaw.end()) > 0.1f);
  CHECK(jaw.front() < 0.05f);
}
