#pragma once
// HTTP answers: JSON bodies and errors with the CORS headers the options allow (guard.hpp), each
// counted by status in the metrics.
#include <nlohmann/json.hpp>

#include "beast.hpp"
#include "facecast/server/options.hpp"
#include "facecast/server/protocol.hpp"
#include "metrics.hpp"

namespace facecast::server {

class Responses {
 public:
  Responses(const ServerOptions& options, Metrics& metrics)
      : options_(options), metrics_(metrics) {}

  http::message_generator json(const Request& req, http::status status,
                               const nlohmann::json& body) const;
  /// `req` (optional): the request answered, for its CORS headers.
  http::message_generator error(unsigned version, bool keep_alive, const Problem& problem,
                                const Request* req = nullptr) const;
  /// Counts the answer's status, names the server and sets the payload's length.
  template <class Body>
  http::message_generator finish(http::response<Body>&& res) const {
    count(res.result_int());
    res.set(http::field::server, "facecast");
    res.prepare_payload();
    return http::message_generator(std::move(res));
  }
  void count(unsigned status) const;

  const ServerOptions& options() const noexcept { return options_; }

 private:
  const ServerOptions& options_;
  Metrics& metrics_;
};

}  // namespace facecast::server
