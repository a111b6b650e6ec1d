#pragma once
// The server's services, made once when it starts (server.cpp) and handed to the code that uses
// them: each piece takes only the services it needs (a stream its StreamServices, a handler the
// registry or queue it calls); the HTTP and WebSocket sessions, which route requests to all of
// them, hold the whole set. Every service lives as long as the last piece holding one (pieces
// hold them through shared pointers that keep the whole set alive).
#include <boost/asio/thread_pool.hpp>
#include <filesystem>
#include <memory>

#include "access.hpp"
#include "api.hpp"
#include "auth.hpp"
#include "facecast/server/options.hpp"
#include "facecast/server/protocol.hpp"
#include "jobs.hpp"
#include "metrics.hpp"
#include "peer_limits.hpp"
#include "redis_bus.hpp"
#include "responses.hpp"
#include "rigs.hpp"
#include "sessions.hpp"
#include "speech.hpp"
#include "storage.hpp"
#include "stream_services.hpp"

namespace facecast::server {

class ChannelRegistry;  // channel.hpp

/// Removes what a killed server left half-written (temporary files and folders: is_temp_name) in
/// the data folder, its rigs/, renders/ and tmp/, and, older than an hour (another instance may
/// be writing there now), in shared_dir's rigs/ and renders/. Logs one line; returns the count.
std::size_t sweep_leftovers(const ServerOptions& options);

/// The folders the page and its scripts are served from (ServerOptions', resolved).
struct WebRoots {
  explicit WebRoots(const ServerOptions& options);
  std::filesystem::path web, three, three_vrm, client;
};

struct Services {
  explicit Services(ServerOptions opts);

  const ServerOptions options;
  Metrics metrics;
  Responses responses;  // JSON answers and errors, counted by status
  Sessions sessions;    // ready, stopping, ids, the live connections
  Auth auth;            // keys, the old token and viewer tokens: who is calling
  WebRoots web;
  RigRegistry rigs;
  Rendering rendering;
  Speech speech;
  ProtocolLimits limits;
  ClientAddresses addresses;  // connections per client address
  BodyMemory body_memory;     // request body bytes held at once (max_body_memory)
  // Many instances: set when ServerOptions::redis.url is (redis_bus.hpp).
  std::unique_ptr<RedisBus> redis;
  // Short work: speech analysis, rendering, request bodies. Declared after everything it uses.
  boost::asio::thread_pool workers;
  StreamServices streams;  // what streams use, as references into the above
  Jobs jobs;
  Storage storage;  // what tenants keep on disk: quotas and rig retention
  // The configured channels; set by the server before any thread runs, dropped after they ended.
  std::shared_ptr<ChannelRegistry> channels;
  Access access;   // who may use which rig, upload and channel
  RigApi rig_api;  // POST /api/rigs, /api/render, /api/photo, ...
};

/// `part` of the services `all`, keeping all of them alive as long as it is held.
template <class T>
std::shared_ptr<T> share(const std::shared_ptr<Services>& all, T& part) {
  return std::shared_ptr<T>(all, &part);
}

}  // namespace facecast::server
