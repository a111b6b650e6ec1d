#pragma once
// What the speaking streams use of the server's services (speak queues, stream pacers, channels,
// their RTMP and VMC outputs): references into services.hpp's set, held through a shared pointer
// that keeps the set alive.
#include <boost/asio/thread_pool.hpp>

#include "facecast/server/options.hpp"
#include "metrics.hpp"
#include "rigs.hpp"
#include "sessions.hpp"
#include "speech.hpp"

namespace facecast::server {

class RedisBus;

struct StreamServices {
  const ServerOptions& options;
  Metrics& metrics;
  Sessions& sessions;  // stream and member ids, stopping
  RigRegistry& rigs;
  Rendering& rendering;  // RTMP's renderers and ffmpeg
  Speech& speech;
  boost::asio::thread_pool& workers;  // analysis and rendering
  RedisBus* redis;                    // many instances: channels publish their messages
};

}  // namespace facecast::server
