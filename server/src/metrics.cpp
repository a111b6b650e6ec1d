#include "metrics.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>

#include "clock.hpp"

namespace facecast::server {
namespace {

std::string num(double v) {
  if (std::isinf(v)) return v > 0 ? "+Inf" : "-Inf";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.15g", v);  // exact for counters and Unix times in ms
  return buf;
}

void header(std::string& out, const char* name, const char* type, const char* help) {
  out += "# HELP ";
  out += name;
  out += ' ';
  out += help;
  out += "\n# TYPE ";
  out += name;
  out += ' ';
  out += type;
  out += '\n';
}

// One line "name{labels} value" (`labels` may be empty).
void sample(std::string& out, const char* name, const std::string& labels,
            const std::string& value) {
  out += name;
  if (!labels.empty()) out += "{" + labels + "}";
  out += ' ';
  out += value;
  out += '\n';
}

template <class T>
void metric(std::string& out, const char* name, const char* type, const char* help, T value) {
  header(out, name, type, help);
  sample(out, name, {}, num(static_cast<double>(value)));
}

void per_output(std::string& out, const char* name, const char* help, const PerOutput& counter) {
  header(out, name, "counter", help);
  sample(out, name, "output=\"weights\"",
         std::to_string(counter.weights.load(std::memory_order_relaxed)));
  sample(out, name, "output=\"frames\"",
         std::to_string(counter.frames.load(std::memory_order_relaxed)));
}

void histogram(std::string& out, const char* name, const char* help, const Histogram& h) {
  header(out, name, "histogram", help);
  h.render(out, name);
}

}  // namespace

Histogram::Histogram(std::vector<double> bounds)
    : bounds_(std::move(bounds)),
      counts_(std::make_unique<std::atomic<std::uint64_t>[]>(bounds_.size() + 1)) {
  for (std::size_t i = 0; i <= bounds_.size(); ++i) counts_[i].store(0);
}

void Histogram::observe(double value) noexcept {
  std::size_t i = 0;
  while (i < bounds_.size() && value > bounds_[i]) ++i;
  counts_[i].fetch_add(1, std::memory_order_relaxed);
  const double micros = std::max(0.0, value) * 1e6;
  sum_micros_.fetch_add(static_cast<std::uint64_t>(micros + 0.5), std::memory_order_relaxed);
  count_.fetch_add(1, std::memory_order_relaxed);
}

void Histogram::render(std::string& out, const std::string& name, const std::string& labels) const {
  std::uint64_t cumulative = 0;
  const std::string sep = labels.empty() ? "" : labels + ",";
  for (std::size_t i = 0; i <= bounds_.size(); ++i) {
    cumulative += counts_[i].load(std::memory_order_relaxed);
    const double le = i < bounds_.size() ? bounds_[i] : INFINITY;
    out += name + "_bucket{" + sep + "le=\"" + num(le) + "\"} " + std::to_string(cumulative) + "\n";
  }
  const std::string l = labels.empty() ? "" : "{" + labels + "}";
  out += name + "_sum" + l + " " + num(sum_micros_.load(std::memory_order_relaxed) / 1e6) + "\n";
  out += name + "_count" + l + " " + std::to_string(count_.load(std::memory_order_relaxed)) + "\n";
}

Metrics::Metrics()
    : http_request_seconds({0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 5}),
      time_to_first_frame_seconds(
          {0.001, 0.0025, 0.005, 0.01, 0.02, 0.03, 0.05, 0.1, 0.25, 0.5, 1, 2.5}),
      analysis_seconds({0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5}),
      render_seconds({0.002, 0.005, 0.01, 0.015, 0.02, 0.03, 0.05, 0.1, 0.25}),
      rig_build_seconds({1, 5, 10, 30, 60, 120, 300, 600, 1800}),
      video_render_seconds({1, 5, 10, 30, 60, 120, 300, 600}),
      start_time(unix_now()) {}

std::string Metrics::render() const {
  std::string out;
  out.reserve(8192);
  auto g = [](const auto& a) { return a.load(std::memory_order_relaxed); };
  metric(out, "process_start_time_seconds", "gauge",
         "Start time of the process since the Unix epoch in seconds.", start_time);
  header(out, "facecast_build_info", "gauge", "The running build (always 1).");
  sample(out, "facecast_build_info",
         "version=\"" FACECAST_VERSION "\",compiler=\"" __VERSION__
         "\",build_type=\"" FACECAST_BUILD_TYPE "\"",
         "1");
  metric(out, "facecast_http_connections", "gauge", "Open HTTP connections (not upgraded).",
         g(http_connections));
  metric(out, "facecast_websocket_connections", "gauge", "Open WebSocket connections.",
         g(ws_connections));
  metric(out, "facecast_connections_total", "counter", "Accepted TCP connections.",
         g(connections_total));
  metric(out, "facecast_connections_refused_total", "counter",
         "Connections refused by max_connections or shutdown.", g(connections_refused_total));
  metric(out, "facecast_active_streams", "gauge", "Utterances being streamed.", g(active_streams));
  metric(out, "facecast_speak_queue_depth", "gauge",
         "Utterances waiting behind the playing one, all connections.", g(speak_queue_depth));
  metric(out, "facecast_write_queue_depth", "gauge",
         "Outgoing WebSocket messages queued, all connections.", g(write_queue_depth));
  metric(out, "facecast_streams_total", "counter", "Streams started.", g(streams_total));
  metric(out, "facecast_streams_cancelled_total", "counter", "Streams ended by cancel.",
         g(streams_cancelled_total));
  per_output(out, "facecast_frames_sent_total", "Frames sent, by output.", frames_sent);
  per_output(out, "facecast_frames_dropped_total",
             "Frames dropped (weights: oldest queued) or skipped (frames), by output.",
             frames_dropped);
  metric(out, "facecast_audio_samples_sent_total", "counter", "PCM samples sent.",
         g(audio_samples_sent_total));
  metric(out, "facecast_websocket_messages_received_total", "counter",
         "WebSocket messages received.", g(ws_messages_received_total));
  metric(out, "facecast_websocket_sent_bytes_total", "counter", "WebSocket payload bytes written.",
         g(ws_bytes_sent_total));
  metric(out, "facecast_slow_clients_closed_total", "counter",
         "Connections closed with 1008 for not reading.", g(slow_clients_closed_total));
  metric(out, "facecast_protocol_errors_total", "counter", "error messages sent.",
         g(protocol_errors_total));
  metric(out, "facecast_http_requests_total", "counter", "HTTP requests handled.",
         g(http_requests_total));
  header(out, "facecast_http_responses_total", "counter", "HTTP responses by status code.");
  for (std::size_t code = 100; code < http_responses_by_code.size(); ++code) {
    const auto n = g(http_responses_by_code[code]);
    if (n)
      sample(out, "facecast_http_responses_total", "code=\"" + std::to_string(code) + "\"",
             std::to_string(n));
  }
  header(out, "facecast_jobs", "gauge", "Jobs (rig builds, video renders) by state.");
  sample(out, "facecast_jobs", "state=\"queued\"", std::to_string(g(jobs_queued)));
  sample(out, "facecast_jobs", "state=\"running\"", std::to_string(g(jobs_running)));
  metric(out, "facecast_jobs_done_total", "counter", "Jobs finished.", g(jobs_done_total));
  metric(out, "facecast_jobs_failed_total", "counter", "Jobs failed or cancelled.",
         g(jobs_failed_total));
  histogram(out, "facecast_http_request_duration_seconds",
            "HTTP request latency (request read to response written).", http_request_seconds);
  histogram(out, "facecast_time_to_first_frame_seconds",
            "From a speak reaching the front of its queue to its first frame being queued.",
            time_to_first_frame_seconds);
  histogram(out, "facecast_analysis_duration_seconds",
            "Speech analysis and animation set-up per utterance.", analysis_seconds);
  histogram(out, "facecast_render_duration_seconds", "Rendering and JPEG encoding of one frame.",
            render_seconds);
  histogram(out, "facecast_rig_build_duration_seconds", "Rig build jobs.", rig_build_seconds);
  histogram(out, "facecast_video_render_duration_seconds", "Video render jobs.",
            video_render_seconds);
  return out;
}

}  // namespace facecast::server
