#pragma once
// Counters, gauges and histograms for GET /metrics (Prometheus text format 0.0.4). Lock-free:
// every value is an atomic that any thread may update.
#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace facecast::server {

class Histogram {
 public:
  explicit Histogram(std::vector<double> bounds);
  void observe(double value) noexcept;
  /// Appends the _bucket/_sum/_count lines of `name` (with optional extra labels "a=\"b\"").
  void render(std::string& out, const std::string& name, const std::string& labels = {}) const;

 private:
  std::vector<double> bounds_;
  std::unique_ptr<std::atomic<std::uint64_t>[]> counts_;  // one per bound, then +Inf
  std::atomic<std::uint64_t> sum_micros_{0};
  std::atomic<std::uint64_t> count_{0};
};

/// One owner's part of a gauge (a connection, a queue, a stream): the gauge is the sum of the
/// parts, and a part leaves the gauge with its owner, so that no code balances it by hand.
class GaugeShare {
 public:
  explicit GaugeShare(std::atomic<long>& gauge, long value = 0) noexcept : gauge_(gauge) {
    set(value);
  }
  ~GaugeShare() { set(0); }
  GaugeShare(const GaugeShare&) = delete;
  GaugeShare& operator=(const GaugeShare&) = delete;

  void set(long value) noexcept {
    gauge_.fetch_add(value - value_);
    value_ = value;
  }

 private:
  std::atomic<long>& gauge_;
  long value_ = 0;
};

/// A counter with the label output="weights" | "frames".
struct PerOutput {
  std::atomic<std::uint64_t> weights{0}, frames{0};
  std::atomic<std::uint64_t>& of(bool frames_output) { return frames_output ? frames : weights; }
};

struct Metrics {
  Metrics();

  // Connections
  std::atomic<long> http_connections{0};
  std::atomic<long> ws_connections{0};
  std::atomic<std::uint64_t> connections_total{0};
  std::atomic<std::uint64_t> connections_refused_total{0};
  // Streams
  std::atomic<long> active_streams{0};
  std::atomic<long> speak_queue_depth{0};  // waiting utterances, all connections
  std::atomic<long> write_queue_depth{0};  // queued outgoing messages, all connections
  std::atomic<std::uint64_t> streams_total{0};
  std::atomic<std::uint64_t> streams_cancelled_total{0};
  PerOutput frames_sent;
  PerOutput frames_dropped;  // weights: dropped from the queue; frames: skipped
  std::atomic<std::uint64_t> audio_samples_sent_total{0};
  // WebSocket traffic
  std::atomic<std::uint64_t> ws_messages_received_total{0};
  std::atomic<std::uint64_t> ws_bytes_sent_total{0};
  std::atomic<std::uint64_t> slow_clients_closed_total{0};
  std::atomic<std::uint64_t> protocol_errors_total{0};
  // HTTP
  std::atomic<std::uint64_t> http_requests_total{0};
  std::array<std::atomic<std::uint64_t>, 600> http_responses_by_code{};  // index: status 100..599
  // Jobs
  std::atomic<long> jobs_queued{0};
  std::atomic<long> jobs_running{0};
  std::atomic<std::uint64_t> jobs_done_total{0};
  std::atomic<std::uint64_t> jobs_failed_total{0};

  Histogram http_request_seconds;
  Histogram time_to_first_frame_seconds;
  Histogram analysis_seconds;  // speech analysis + animation set-up per utterance
  Histogram render_seconds;    // one frame: render + JPEG
  Histogram rig_build_seconds;
  Histogram video_render_seconds;

  /// Unix time at which the server started (process_start_time_seconds).
  double start_time = 0;

  std::string render() const;
};

}  // namespace facecast::server
