#include "responses.hpp"

#include "guard.hpp"

namespace facecast::server {

void Responses::count(unsigned status) const {
  if (status >= 100 && status < metrics_.http_responses_by_code.size())
    metrics_.http_responses_by_code[status].fetch_add(1);
}

http::message_generator Responses::json(const Request& req, http::status status,
                                        const nlohmann::json& body) const {
  http::response<http::string_body> res{status, req.version()};
  res.set(http::field::content_type, "application/json");
  res.set(http::field::cache_control, "no-store");
  res.keep_alive(req.keep_alive());
  add_cors(options_, req, res);
  if (req.method() != http::verb::head)
    res.body() = body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  return finish(std::move(res));
}

http::message_generator Responses::error(unsigned version, bool keep_alive, const Problem& problem,
                                         const Request* req) const {
  http::response<http::string_body> res{static_cast<http::status>(problem.status), version};
  res.set(http::field::content_type, "application/json");
  res.set(http::field::cache_control, "no-store");
  if (problem.status == 401) res.set(http::field::www_authenticate, "Bearer");
  res.keep_alive(keep_alive);
  if (req) add_cors(options_, *req, res);
  res.body() = error_body(problem) + "\n";
  return finish(std::move(res));
}

}  // namespace facecast::server
