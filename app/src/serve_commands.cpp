// facecast serve [--config configs/server.json] [--host H] [--port P] [--data DIR] [--token T]
//                [--redis URL]
#include <cstdio>
#include <cstdlib>

#include "facecast/app/commands.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/error.hpp"
#include "facecast/server/server.hpp"

namespace facecast::cli {
namespace {

struct ServeArgs {
  std::string config, host, data, token, web, log_level, redis;
  int port = -1;
};

void run_serve(const ServeArgs& a) {
  // Checked once the command line has had its say (--host, --data, --token).
  server::ServerOptions o = a.config.empty()
                                ? server::read_server_options(config_path("server.json"))
                                : server::read_server_options(a.config);
  if (!a.host.empty()) o.host = a.host;
  if (a.port >= 0) o.port = a.port;
  if (!a.data.empty()) o.data = a.data;
  if (!a.web.empty()) o.web_root = std::filesystem::absolute(a.web);
  if (!a.log_level.empty()) o.log_level = a.log_level;
  if (!a.redis.empty()) o.redis.url = a.redis;
  if (!a.token.empty()) {
    o.token = a.token;
  } else if (const char* env = std::getenv("FACECAST_TOKEN"); env && *env) {
    o.token = env;
  }
  server::validate(o);
  server::Server s(o);
  s.handle_signals();
  s.start();
  // One line on stdout that scripts (and the tests) read for the chosen port.
  std::printf("facecast: listening on %s\n", s.url().c_str());
  std::fflush(stdout);
  s.wait();
}

}  // namespace

void add_serve_commands(CLI::App& app) {
  auto a = std::make_shared<ServeArgs>();
  auto* cmd = app.add_subcommand(
      "serve", "Run the server: web client, REST API and the facecast.v1 WebSocket stream");
  cmd->add_option("--config", a->config, "Server config (default: configs/server.json)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--host", a->host,
                  "Address to bind (default 127.0.0.1; anything else needs a key store: "
                  "facecast keys create)");
  cmd->add_option("--port", a->port, "Port (default 8080; 0 picks a free one and prints it)")
      ->check(CLI::Range(0, 65535));
  cmd->add_option("--data", a->data, "Folder for built rigs and rendered videos (default data/)");
  cmd->add_option("--token", a->token,
                  "The single admin key of older versions, accepted on /api and /ws (also "
                  "$FACECAST_TOKEN); API keys (facecast keys create) are the way now");
  cmd->add_option("--web", a->web, "Folder of the web client (default: web/ of the project)")
      ->check(CLI::ExistingDirectory);
  cmd->add_option(
      "--redis", a->redis,
      "Redis for many instances: redis://[:password@]host[:port][/db] (config: redis.url)");
  cmd->add_option("--log-level", a->log_level, "debug, info, warn or error")
      ->check(CLI::IsMember({"debug", "info", "warn", "error"}));
  cmd->callback([a] { run_serve(*a); });
}

}  // namespace facecast::cli
