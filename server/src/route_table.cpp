#include "route_table.hpp"

#include <array>

namespace facecast::server {

std::span<const Route> http_routes() {
  static constexpr std::array kRoutes = {
      Route{"GET", "/healthz", ""},
      Route{"GET", "/readyz", ""},
      Route{"GET", "/metrics", "metrics"},
      Route{"GET", "/ws", "speak | channels:subscribe | channels:produce"},
      Route{"GET", "/api/openapi.json", ""},
      Route{"GET", "/api/rigs", "rigs:read"},
      Route{"POST", "/api/rigs", "rigs:write"},
      Route{"PATCH", "/api/rigs/{id}", "rigs:write"},
      Route{"DELETE", "/api/rigs/{id}", "rigs:write"},
      Route{"GET", "/api/rigs/{id}.glb", "rigs:read"},
      Route{"GET", "/api/rigs/{id}/virtual_edges.json", "rigs:read"},
      Route{"POST", "/api/tokens", "the token's scope"},
      Route{"POST", "/api/photo", "rigs:write"},
      Route{"POST", "/api/photo/landmarks", "rigs:write"},
      Route{"POST", "/api/landmarks", "rigs:write"},
      Route{"POST", "/api/render", "render"},
      Route{"POST", "/api/audio", "speak"},
      Route{"GET", "/api/jobs/{id}", "render | rigs:write (by the job's kind)"},
      Route{"DELETE", "/api/jobs/{id}", "render | rigs:write (by the job's kind)"},
      Route{"GET", "/api/jobs/{id}/video.mp4", "render"},
      Route{"GET", "/api/channels/{c}", "channels:subscribe"},
      Route{"POST", "/api/channels/{c}/speak",
            "channels:produce (or the channel's producer token)"},
  };
  return kRoutes;
}

}  // namespace facecast::server
