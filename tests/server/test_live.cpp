// Live shows against the real server: a channel fans one stream out to many subscribers (the
// same bytes to each, late joiners from the current frame, presence, HTTP and WebSocket producers,
// cancel, a stalled subscriber that slows nobody), and incremental text (append / end) spoken
// piece by piece without gaps, every word once.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cctype>
#include <sstream>
#include <thread>

#include "client.hpp"

using namespace fctest;
using facecast::server::MediaKind;
using facecast::server::ServerOptions;
using Clock = std::chrono::steady_clock;

namespace {

void with_channel(ServerOptions& o) {
  o.channels.push_back({"show", kProducerToken});
  o.presence_interval = 0.2;
  o.channel_idle = 0;  // idle-life streams have their own test
}

// Reads text messages until one of `type` (others are kept in `seen`), for up to `timeout`
// seconds at full speed (longer under a sanitizer).
nlohmann::json wait_for(WsClient& c, const std::string& type, double timeout = 10,
                        std::vector<nlohmann::json>* seen = nullptr) {
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                           std::chrono::duration<double>(timeout * slowdown()));
  while (Clock::now() < deadline) {
    const auto m = c.read(std::chrono::duration<double>(deadline - Clock::now()).count());
    if (!m) break;
    if (!m->text) continue;
    auto j = m->json();
    if (j["type"] == type) return j;
    if (seen) seen->push_back(j);
  }
  throw std::runtime_error("no '" + type + "' message");
}

std::unique_ptr<WsClient> subscriber(unsigned short port, WsClient::Options options = {}) {
  auto c = std::make_unique<WsClient>(port, options);
  REQUIRE(c->read_json(10 * slowdown())["type"] == "hello");
  c->send(nlohmann::json{{"type", "subscribe"}, {"channel", "show"}});
  if (options.receive_buffer == 0) {
    const auto j = wait_for(*c, "subscribed");
    CHECK(j["channel"] == "show");
  }
  return c;
}

std::unique_ptr<WsClient> producer(unsigned short port) {
  auto c = std::make_unique<WsClient>(port);
  REQUIRE(c->read_json(10 * slowdown())["type"] == "hello");
  c->send(nlohmann::json{{"type", "produce"}, {"channel", "show"}, {"token", kProducerToken}});
  CHECK(wait_for(*c, "producing")["channel"] == "show");
  return c;
}

// Frames [from, end) arrived once each, in order.
void check_contiguous(const StreamResult& r, std::uint32_t from) {
  std::uint32_t next = from;
  for (const auto& w : r.weights) {
    REQUIRE(w.header.first == next);
    next += w.header.count;
  }
  CHECK(next == r.start["frames"].get<std::uint32_t>());
}

std::vector<std::string> words_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string w; in >> w;) {
    std::string clean;
    for (const char c : w)
      if (std::isalnum(static_cast<unsigned char>(c)))
        clean += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (!clean.empty()) out.push_back(clean);
  }
  return out;
}

}  // namespace

TEST_CASE("a channel streams one utterance to every subscriber", "[ws][channel]") {
  TestServer s(with_channel);
  std::vector<std::unique_ptr<WsClient>> subs;
  for (int i = 0; i < 3; ++i) subs.push_back(subscriber(s.port()));
  // A subscriber that never reads (a tiny receive buffer): it must slow nobody.
  WsClient::Options tiny;
  tiny.receive_buffer = 4096;
  auto stalled = subscriber(s.port(), tiny);

  auto prod = std::make_unique<WsClient>(s.port());
  REQUIRE(prod->read_json(10 * slowdown())["type"] == "hello");
  // Without the producer token nothing can be said on the channel.
  prod->send(nlohmann::json{{"type", "speak"}, {"id", "x"}, {"text", "hi."}, {"channel", "show"}});
  CHECK(wait_for(*prod, "error")["code"] == "forbidden");
  prod->send(nlohmann::json{{"type", "produce"}, {"channel", "show"}, {"token", "wrong-token"}});
  CHECK(wait_for(*prod, "error")["code"] == "unauthorized");
  prod->send(nlohmann::json{{"type", "subscribe"}, {"channel", "nope"}});
  CHECK(wait_for(*prod, "error")["code"] == "not_found");
  prod = producer(s.port());

  prod->send(nlohmann::json{{"type", "speak"},
                            {"id", "s1"},
                            {"channel", "show"},
                            {"text", "Good evening, and welcome to the show. Tonight we talk."}});
  std::vector<StreamResult> results;
  for (auto& c : subs) results.push_back(collect_stream(*c, "s1"));
  for (const auto& r : results) {
    REQUIRE_FALSE(r.error);
    CHECK(r.start["stream"] == results[0].start["stream"]);
    check_contiguous(r, 0);
    CHECK(r.end["cancelled"] == false);
    // Encoded once: the same values, frame for frame, for every subscriber.
    REQUIRE(r.weights.size() == results[0].weights.size());
    for (std::size_t i = 0; i < r.weights.size(); ++i)
      REQUIRE(r.weights[i].values == results[0].weights[i].values);
    std::size_t samples = 0;
    for (const auto& a : r.audio) samples += a.samples;
    CHECK(samples == r.start["audio"]["samples"].get<std::size_t>());
  }
  // Channel pacing (docs/algorithms.md#stream-pacing): messages of min_tick (two frames at
  // 60 fps), sent one to two channel_ticks before they are due, in writes of several messages.
  const auto& o = s.options();
  std::vector<double> early;
  std::size_t writes = 0;  // groups of messages arriving within 10 ms of each other
  for (const auto& w : results[0].weights) {
    CHECK(w.header.count <= 2);
    const double due = w.header.pts - o.lead;  // after stream_start, the server's schedule
    if (due > 2 * o.channel_tick)
      early.push_back(due - std::chrono::duration<double>(w.at - results[0].start_at).count());
    writes +=
        &w == &results[0].weights.front() || w.at - (&w)[-1].at > std::chrono::milliseconds(10);
  }
  REQUIRE(early.size() > 20);
  std::sort(early.begin(), early.end());
  CHECK(early[early.size() / 2] > 0.5 * o.channel_tick);  // the median frame: well ahead
  CHECK(writes < results[0].weights.size() / 2);          // several messages a write
  // Presence: every subscriber learns the count (4 with the stalled one) within presence_interval.
  bool presence = false;
  for (const auto& j : results[0].others)
    presence = presence || (j["type"] == "presence" && j["subscribers"] == 4);
  if (!presence) CHECK(wait_for(*subs[0], "presence")["subscribers"] == 4);

  // HTTP producer: the channel's producer token is required.
  const std::string body = R"({"id": "h1", "text": "A word from the newsroom, and then more."})";
  CHECK(http_request(s.port(), http::verb::post, "/api/channels/show/speak", body).status == 401);
  CHECK(http_request(s.port(), http::verb::post, "/api/channels/nope/speak", body,
                     {{"Authorization", std::string("Bearer ") + kProducerToken}})
            .status == 404);
  const auto posted = http_request(s.port(), http::verb::post, "/api/channels/show/speak", body,
                                   {{"Authorization", std::string("Bearer ") + kProducerToken}});
  REQUIRE(posted.status == 202);
  CHECK(posted.json()["id"] == "h1");
  // A late joiner gets the stream from the current frame on.
  const auto first = collect_stream(*subs[0], "h1", 30 * slowdown());
  (void)first;
  const auto j =
      nlohmann::json::parse(http_request(s.port(), http::verb::get, "/api/channels/show").body);
  CHECK(j["subscribers"] == 4);
  const auto metrics = http_request(s.port(), http::verb::get, "/metrics").body;
  CHECK(metric_value(metrics, "facecast_channel_subscribers{channel=\"show\"}") == 4);

  prod->send(nlohmann::json{{"type", "speak"},
                            {"id", "s2"},
                            {"channel", "show"},
                            {"text",
                             "This is a long sentence that will be interrupted by the "
                             "producer before it is over, so it fades to rest."}});
  (void)collect_stream(*subs[1], "h1", 30 * slowdown());
  const auto started = wait_for(*subs[1], "stream_start");
  REQUIRE(started["id"] == "s2");
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  auto late = subscriber(s.port());  // `subscribed` was read; the stream_start follows
  const auto late_start = wait_for(*late, "stream_start");
  CHECK(late_start["id"] == "s2");
  prod->send(nlohmann::json{{"type", "cancel"}, {"id", "s2"}, {"channel", "show"}});
  const auto late_r = collect_stream(*late, "s2", 30 * slowdown(), &late_start);
  REQUIRE_FALSE(late_r.weights.empty());
  CHECK(late_r.weights.front().header.first > 20);  // joined at the current frame, not at 0
  CHECK(late_r.end["cancelled"] == true);
  const auto full = collect_stream(*subs[1], "s2", 30 * slowdown(), &started);
  CHECK(full.end["cancelled"] == true);
  CHECK(full.weights.front().header.first == 0);
  CHECK(full.weights.back().header.first + full.weights.back().header.count ==
        late_r.weights.back().header.first + late_r.weights.back().header.count);
}

// Reads one open stream `id` to its stream_end: the messages it had, in order.
struct OpenStream {
  nlohmann::json start, end;
  std::vector<nlohmann::json> segments, errors;
  std::vector<facecast::server::MediaHeader> weights, audio;
};

OpenStream read_open_stream(WsClient& c) {
  OpenStream r;
  while (r.end.is_null()) {
    auto m = c.read(60);
    REQUIRE(m);
    if (!m->text) {
      const auto h = facecast::server::read_header(m->data);
      (h.kind == MediaKind::kAudio ? r.audio : r.weights).push_back(h);
      continue;
    }
    const auto j = m->json();
    if (j["type"] == "stream_start") r.start = j;
    if (j["type"] == "segment") r.segments.push_back(j);
    if (j["type"] == "stream_end") r.end = j;
    if (j["type"] == "error") r.errors.push_back(j);
  }
  return r;
}

// One stream, frames and samples contiguous from 0, every word once and in order; returns the
// samples sent.
std::uint32_t check_open_stream(const OpenStream& r, const std::vector<std::string>& words) {
  REQUIRE(r.start["open"] == true);
  CHECK(r.start["frames"].is_null());
  CHECK(r.end["cancelled"] == false);
  std::uint32_t next = 0;
  for (const auto& h : r.weights) {
    REQUIRE(h.first == next);
    next += h.count;
  }
  CHECK(static_cast<int>(next) == r.end["frames"].get<int>());
  std::uint32_t sample = 0;
  for (const auto& h : r.audio) {
    REQUIRE(h.first == sample);
    sample += h.count;
  }
  std::string said = r.start["utterance"]["text"];
  for (const auto& seg : r.segments) said += " " + seg["utterance"]["text"].get<std::string>();
  CHECK(words_of(said) == words);
  return sample;
}

TEST_CASE("incremental text on a connection's own stream", "[ws][incremental]") {
  TestServer s;
  WsClient c(s.port());
  REQUIRE(c.read_json(10 * slowdown())["type"] == "hello");
  c.send(nlohmann::json{{"type", "speak"}, {"id", "p1"}, {"text", "Hello the"}, {"more", true}});
  c.send(nlohmann::json{{"type", "append"}, {"id", "p1"}, {"text", "re. How are"}});
  c.send(nlohmann::json{{"type", "append"}, {"id", "p0"}, {"text", "x"}});  // unknown id
  c.send(nlohmann::json{{"type", "append"}, {"id", "p1"}, {"text", " you today"}});
  c.send(nlohmann::json{{"type", "end"}, {"id", "p1"}});
  c.send(nlohmann::json{{"type", "append"}, {"id", "p1"}, {"text", "too late"}});
  const OpenStream r = read_open_stream(c);
  CHECK(r.segments.size() == 1);
  check_open_stream(r, words_of("Hello there. How are you today"));
  REQUIRE(r.errors.size() == 2);
  CHECK(r.errors[0]["code"] == "not_found");
  CHECK(r.errors[1]["id"] == "p1");
  // A speak that is not open takes no append.
  c.send(nlohmann::json{{"type", "speak"}, {"id", "p2"}, {"text", "Short."}});
  c.send(nlohmann::json{{"type", "append"}, {"id", "p2"}, {"text", "more"}});
  CHECK(wait_for(c, "error")["code"] == "invalid_input");
}

TEST_CASE("incremental text fed in 3-word pieces has no gaps", "[ws][incremental][channel]") {
  TestServer s(with_channel);
  auto viewer = subscriber(s.port());
  auto prod = producer(s.port());
  const std::string paragraph =
      "The weather today is calm and bright. Later in the evening a light rain may reach the "
      "coast, so take a coat. Tomorrow the sun returns and the wind stays low.";
  const auto words = words_of(paragraph);
  // The words in 3-word pieces (with their spaces), sent 200 ms apart while the stream plays.
  std::vector<std::string> pieces((words.size() + 2) / 3);
  {
    std::istringstream in(paragraph);
    std::size_t n = 0;
    for (std::string w; in >> w; ++n) pieces[n / 3] += w + " ";
  }
  prod->send(nlohmann::json{
      {"type", "speak"}, {"id", "p1"}, {"channel", "show"}, {"text", ""}, {"more", true}});
  std::thread feeder([&] {
    for (const auto& piece : pieces) {
      prod->send(
          nlohmann::json{{"type", "append"}, {"id", "p1"}, {"channel", "show"}, {"text", piece}});
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
    prod->send(nlohmann::json{{"type", "end"}, {"id", "p1"}, {"channel", "show"}});
  });
  const OpenStream r = read_open_stream(*viewer);
  feeder.join();
  CHECK(r.errors.empty());
  const std::uint32_t samples = check_open_stream(r, words);
  // Several pieces (sentences); no gap longer than a normal pause between one piece's speech and
  // the next.
  REQUIRE(r.segments.size() >= 2);
  double speech_end = r.start["utterance"]["duration"];
  for (const auto& seg : r.segments) {
    const double gap = seg["start"].get<double>() - speech_end;
    CHECK(gap >= -0.5e-4 - 1e-9);  // the utterance JSON's times are rounded to 0.1 ms
    CHECK(gap < 0.5);
    speech_end = seg["start"].get<double>() + seg["utterance"]["duration"].get<double>();
    CHECK(seg["end_sample"].get<std::size_t>() <= samples);
  }
}

TEST_CASE("a channel plays idle life between utterances and gives way to speech", "[ws][channel]") {
  TestServer s([](ServerOptions& o) {
    o.channels.push_back({"show", kProducerToken});
    o.channel_idle = 1.5;
  });
  auto viewer = subscriber(s.port());
  // With a subscriber and nothing to say, the channel streams idle life, stream after stream.
  const auto idle = wait_for(*viewer, "stream_start");
  CHECK(idle["id"] == "~idle");
  CHECK(idle["audio"].is_null());
  const auto r = collect_stream(*viewer, "~idle", 10 * slowdown(), &idle);
  check_contiguous(r, 0);
  CHECK(r.end["cancelled"] == false);
  const double fps = idle["fps"];
  CHECK(r.start["frames"] == static_cast<int>(std::ceil(1.5 * fps - 1e-9)));
  // Blinks and head motion: the weights change over the stream.
  float change = 0;
  for (const auto& w : r.weights)
    for (std::size_t i = 0; i < w.values.size(); ++i)
      change =
          std::max(change, std::abs(w.values[i] - r.weights.front().values[i % w.values.size()]));
  CHECK(change > 0.0f);
  const auto next = wait_for(*viewer, "stream_start");
  CHECK(next["id"] == "~idle");
  // A producer's utterance: the idle stream fades out (cancelled), then the speech plays.
  auto prod = producer(s.port());
  prod->send(nlohmann::json{
      {"type", "speak"}, {"id", "s1"}, {"channel", "show"}, {"text", "Hello, everyone."}});
  const auto idle_end = collect_stream(*viewer, "~idle", 10 * slowdown(), &next);
  const auto speech = collect_stream(*viewer, "s1", 30 * slowdown());
  CHECK(speech.end["cancelled"] == false);
  check_contiguous(speech, 0);
  const auto after = wait_for(*viewer, "stream_start");
  CHECK(after["id"] == "~idle");
  (void)idle_end;
}
