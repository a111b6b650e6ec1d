#include "facecast/server/server.hpp"

#include <signal.h>
#include <sys/resource.h>
#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/signal_set.hpp>
#include <thread>

#include "api.hpp"
#include "beast.hpp"
#include "channel.hpp"
#include "facecast/core/error.hpp"
#include "facecast/core/subprocess.hpp"
#include "http_session.hpp"
#include "log.hpp"
#include "rtmp_out.hpp"
#include "services.hpp"
#include "speech.hpp"
#include "storage.hpp"
#include "vmc_out.hpp"

namespace facecast::server {
namespace {

// Many WebSocket clients need many descriptors: raise the soft limit to the hard one.
void raise_file_limit() {
  rlimit rl{};
  if (getrlimit(RLIMIT_NOFILE, &rl) == 0 && rl.rlim_cur < rl.rlim_max) {
    rl.rlim_cur = rl.rlim_max;
    setrlimit(RLIMIT_NOFILE, &rl);
  }
}

}  // namespace

struct Server::Impl {
  explicit Impl(ServerOptions options);
  // The channels hold the services: drop them (no thread runs any more) so that they can go.
  ~Impl() {
    rtmp.clear();  // each stops (idempotent) and lets go of its channel
    vmc.clear();
    if (services && services->redis) services->redis->stop();
    if (services) services->channels.reset();
  }

  void do_accept();
  void on_accept(beast::error_code ec, tcp::socket socket);
  void begin_shutdown();
  void check_shutdown();
  void begin_drain();
  void check_drain();

  std::shared_ptr<Services> services;
  net::io_context ioc;
  net::executor_work_guard<net::io_context::executor_type> work;
  // The accept loop, signals, timers and stop() run on this strand: the flags below, the acceptor
  // and the timers are never touched by two I/O threads at once.
  net::strand<net::io_context::executor_type> control;
  tcp::acceptor acceptor;
  net::signal_set signals;
  net::steady_timer shutdown_timer;
  net::steady_timer maintenance_timer;  // rig retention (storage.hpp), every 10 minutes
  void maintain();
  std::chrono::steady_clock::time_point shutdown_deadline;
  std::vector<std::thread> threads;
  std::thread jobs_stopper;  // cancels jobs and ends the RTMP outputs during shutdown
  std::vector<std::shared_ptr<RtmpOutput>> rtmp;  // channels published as live video
  std::vector<std::shared_ptr<VmcMirror>> vmc;    // channels mirrored to VMC receivers
  bool shutting_down = false;                     // on `control`
  bool draining = false;
  std::chrono::steady_clock::time_point drain_deadline;
  std::mutex mutex;
  bool started = false;
};

Server::Impl::Impl(ServerOptions options)
    : ioc(options.io_threads),
      work(net::make_work_guard(ioc)),
      control(net::make_strand(ioc)),
      acceptor(control),
      signals(control),
      shutdown_timer(control),
      maintenance_timer(control) {
  validate(options);
  log::set_level(options.log_level);
  raise_file_limit();
  sweep_leftovers(options);  // before anything opens or lists the data folder
  services = std::make_shared<Services>(std::move(options));
  const auto streams = share(services, services->streams);
  services->channels = std::make_shared<ChannelRegistry>(streams, ioc);
  rtmp = start_rtmp_outputs(streams, *services->channels);
  vmc = start_vmc_mirrors(streams, *services->channels);
  if (services->redis) {
    Services* s = services.get();  // the bus and the jobs stop before the services go
    services->redis->start(services->channels,
                           [s](const std::string& dead) { s->jobs.requeue_instance(dead); });
    services->jobs.start(
        [s](const std::string& kind, const nlohmann::json& payload, const std::string& tenant) {
          return s->rig_api.job_work(kind, payload, tenant);
        });
  }
  const auto& o = services->options;
  beast::error_code ec;
  const std::string host = o.host == "localhost" ? "127.0.0.1" : o.host;
  const auto address = net::ip::make_address(host, ec);
  if (ec) throw Error("host: '" + o.host + "' is not an IP address");
  const tcp::endpoint endpoint(address, static_cast<unsigned short>(o.port));
  acceptor.open(endpoint.protocol(), ec);
  // Asio opens and accepts without close-on-exec: no child (ffmpeg) may hold the listening socket
  // or a client's connection (the spawn also closes them in the child: core/subprocess.hpp).
  if (!ec) set_cloexec(acceptor.native_handle());
  if (!ec) acceptor.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) acceptor.bind(endpoint, ec);
  if (!ec) acceptor.listen(net::socket_base::max_listen_connections, ec);
  if (ec) {
    throw Error("cannot listen on " + o.host + ":" + std::to_string(o.port) + ": " + ec.message(),
                ErrorCode::kInternal);
  }
  maintain();
}

// Folder scans run on the worker pool, never on the I/O threads.
void Server::Impl::maintain() {
  net::post(services->workers, [s = services] { s->storage.expire_rigs(); });
  maintenance_timer.expires_after(std::chrono::minutes(10));
  maintenance_timer.async_wait([this](beast::error_code ec) {
    if (!ec && !shutting_down && !draining) maintain();
  });
}

void Server::Impl::do_accept() {
  acceptor.async_accept(net::make_strand(ioc), beast::bind_front_handler(&Impl::on_accept, this));
}

void Server::Impl::on_accept(beast::error_code ec, tcp::socket socket) {
  if (ec) {
    if (ec == net::error::operation_aborted || !acceptor.is_open()) return;
    log::warn("accept_failed", {{"error", ec.message()}});
    if (ec == net::error::no_descriptors || ec == net::error::no_buffer_space) {
      // Out of descriptors: back off a little instead of spinning.
      auto t = std::make_shared<net::steady_timer>(control, std::chrono::milliseconds(50));
      t->async_wait([this, t](beast::error_code) { do_accept(); });
      return;
    }
    do_accept();
    return;
  }
  auto& o = services->options;
  set_cloexec(socket.native_handle());
  socket.set_option(tcp::no_delay(true), ec);
  if (o.send_buffer > 0) socket.set_option(net::socket_base::send_buffer_size(o.send_buffer), ec);
  const long open = services->sessions.connections.fetch_add(1) + 1;
  auto slot = std::make_unique<ConnectionSlot>(&services->sessions.connections);
  services->metrics.connections_total.fetch_add(1);
  const std::uint64_t id = services->sessions.new_connection_id();
  std::string refused;  // answered with 503 and closed when set
  if (open > o.max_connections) {
    refused = "too many connections (max_connections)";
  } else if (const auto peer = socket.remote_endpoint(ec);
             !ec && !services->addresses.trusted(peer.address())) {
    // A trusted proxy's connections are counted per client at the request (http_session.cpp).
    slot->address = services->addresses.hold(peer.address().to_string());
    if (!slot->address)
      refused = "too many connections from " + peer.address().to_string() +
                " (max_connections_per_address)";
  }
  std::make_shared<HttpSession>(std::move(socket), services, std::move(slot), id,
                                std::move(refused))
      ->run();
  do_accept();
}

void Server::Impl::begin_shutdown() {
  if (shutting_down) return;
  shutting_down = true;
  services->sessions.stopping = true;
  log::info("shutdown", {{"connections", services->sessions.connections.load()}});
  beast::error_code ec;
  acceptor.close(ec);
  signals.cancel(ec);
  services->sessions.shut_down_all();
  services->channels->close_all();
  // Jobs: cancel in the background so that the I/O keeps closing sockets meanwhile.
  jobs_stopper = std::thread([s = services, rtmp = rtmp, vmc = vmc] {
    for (const auto& r : rtmp) r->stop();
    for (const auto& v : vmc) v->stop();
    s->jobs.shutdown();  // with Redis: running jobs go back to the queue
    if (s->redis) s->redis->stop();
  });
  shutdown_deadline = std::chrono::steady_clock::now() +
                      std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                          std::chrono::duration<double>(services->options.shutdown_timeout));
  check_shutdown();
}

// SIGTERM: stop accepting (and /readyz says so), refuse new utterances, let the running ones
// finish for up to drain_timeout, then shut down (close every WebSocket with 1001).
void Server::Impl::begin_drain() {
  if (shutting_down || draining) return;
  draining = true;
  services->sessions.stopping = true;
  log::info("draining", {{"streams", services->metrics.active_streams.load()},
                         {"timeout_s", services->options.drain_timeout}});
  beast::error_code ec;
  acceptor.close(ec);
  services->channels->stop_idle();
  drain_deadline = std::chrono::steady_clock::now() + from_seconds(services->options.drain_timeout);
  check_drain();
}

void Server::Impl::check_drain() {
  if (shutting_down) return;
  const bool done = services->metrics.active_streams.load() == 0 &&
                    services->metrics.speak_queue_depth.load() == 0;
  if (done || std::chrono::steady_clock::now() >= drain_deadline) {
    if (!done) log::warn("drain_timeout", {{"streams", services->metrics.active_streams.load()}});
    begin_shutdown();
    return;
  }
  shutdown_timer.expires_after(std::chrono::milliseconds(50));
  shutdown_timer.async_wait([this](beast::error_code ec) {
    if (!ec) check_drain();
  });
}

void Server::Impl::check_shutdown() {
  const bool idle = services->sessions.connections.load() == 0;
  if (idle || std::chrono::steady_clock::now() >= shutdown_deadline) {
    if (!idle)
      log::warn("shutdown_forced", {{"connections", services->sessions.connections.load()}});
    work.reset();
    ioc.stop();
    return;
  }
  shutdown_timer.expires_after(std::chrono::milliseconds(20));
  shutdown_timer.async_wait([this](beast::error_code) { check_shutdown(); });
}

Server::Server(ServerOptions options) : impl_(std::make_unique<Impl>(std::move(options))) {}

Server::~Server() {
  stop();
  wait();
}

unsigned short Server::port() const {
  return impl_->acceptor.local_endpoint().port();
}

std::string Server::url() const {
  const auto& host = impl_->services->options.host;
  const bool v6 = host.find(':') != std::string::npos;
  return "http://" + (v6 ? "[" + host + "]" : host) + ":" + std::to_string(port());
}

void Server::handle_signals() {
  impl_->signals.add(SIGINT);
  impl_->signals.add(SIGTERM);
  impl_->signals.async_wait([this](beast::error_code ec, int signal) {
    if (ec) return;
    log::info("signal", {{"signal", signal == SIGINT ? "SIGINT" : "SIGTERM"}});
    if (signal == SIGTERM) {
      impl_->begin_drain();
      // A second signal during the drain stops at once.
      impl_->signals.async_wait([this](beast::error_code e, int) {
        if (!e) impl_->begin_shutdown();
      });
      return;
    }
    impl_->begin_shutdown();
  });
}

void Server::start() {
  {
    std::lock_guard lock(impl_->mutex);
    if (impl_->started) return;
    impl_->started = true;
  }
  const auto& o = impl_->services->options;
  log::info("listening", {{"url", url()},
                          {"io_threads", o.io_threads},
                          {"workers", o.workers},
                          {"data", o.data.string()},
                          {"web", impl_->services->web.web.string()},
                          {"token", !o.token.empty()},
                          {"keys", impl_->services->auth.keys() != nullptr}});
  net::dispatch(impl_->control, [this] { impl_->do_accept(); });
  // Warm-up on a worker: the default rig's mapping, the Chinese and English lexicons and
  // espeak-ng's voices are loaded once here rather than during the first client's speak.
  net::post(impl_->services->workers, [s = impl_->services] {
    const auto t0 = std::chrono::steady_clock::now();
    try {
      SpeakRequest r;
      r.text = "你好, hello.";
      r.audio = false;
      r.timing = viseme::Timing::kModel;
      (void)s->speech.prepare(r, 1);
      r.audio = true;
      r.timing = viseme::Timing::kTts;
      (void)s->speech.prepare(r, 1);
      log::info(
          "warm",
          {{"ms", std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                      .count()}});
    } catch (const std::exception& e) {
      log::warn("warm_up_failed", {{"error", e.what()}});
    }
    s->sessions.ready = true;
  });
  for (int i = 0; i < o.io_threads; ++i) {
    impl_->threads.emplace_back([this] { impl_->ioc.run(); });
  }
}

void Server::run() {
  start();
  wait();
}

void Server::stop() {
  net::post(impl_->control, [this] { impl_->begin_shutdown(); });
  {
    std::lock_guard lock(impl_->mutex);
    if (!impl_->started) {
      // Never started: nothing runs the io_context, so shut down here.
      impl_->started = true;
      impl_->threads.emplace_back([this] { impl_->ioc.run(); });
    }
  }
}

void Server::wait() {
  std::vector<std::thread> threads;
  {
    std::lock_guard lock(impl_->mutex);
    threads.swap(impl_->threads);
  }
  for (auto& t : threads) t.join();
  if (threads.empty()) return;
  if (impl_->jobs_stopper.joinable()) impl_->jobs_stopper.join();
  impl_->services->jobs.shutdown();
  impl_->services->workers.join();
  log::info("stopped", {});
}

}  // namespace facecast::server
