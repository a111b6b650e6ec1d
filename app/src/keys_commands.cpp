// facecast keys create --tenant T --scopes speak,render,... [--data DIR] [--config FILE]
// facecast keys list [--json] | facecast keys revoke ID
// API keys of `facecast serve` (docs/security.md): kept hashed in
// <data>/keys.sqlite3 (or the config's "keys" path); a new key is printed once.
#include <cstdio>
#include <ctime>
#include <iostream>
#include <nlohmann/json.hpp>

#include "facecast/app/commands.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/error.hpp"
#include "facecast/server/keys.hpp"

namespace facecast::cli {
namespace {

struct StoreArgs {
  std::string config, data;
};

struct CreateArgs : StoreArgs {
  std::string tenant, scopes;
};

struct ListArgs : StoreArgs {
  bool json = false;
};

struct RevokeArgs : StoreArgs {
  std::string id;
};

std::filesystem::path store_path(const StoreArgs& a) {
  server::ServerOptions o = server::read_server_options(
      a.config.empty() ? config_path("server.json") : std::filesystem::path(a.config));
  if (!a.data.empty()) o.data = a.data;
  return server::key_store_path(o);
}

void add_store_options(CLI::App* cmd, StoreArgs& a) {
  cmd->add_option("--data", a.data,
                  "The server's data folder (default: the config's \"data\"); the store is "
                  "keys.sqlite3 in it")
      ->type_name("DIR");
  cmd->add_option("--config", a.config, "Server config (default: configs/server.json)")
      ->check(CLI::ExistingFile);
}

std::string iso_time(double t) {
  if (t <= 0) return "-";
  const std::time_t secs = static_cast<std::time_t>(t);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

void run_create(const CreateArgs& a) {
  server::check_tenant_name(a.tenant, "--tenant");
  const std::uint32_t scopes = server::parse_scopes(a.scopes);
  server::KeyStore store(store_path(a), true);
  const server::CreatedKey k = store.create(a.tenant, scopes);
  // The key alone on stdout (for scripts); what it is on stderr.
  std::printf("%s\n", k.key.c_str());
  std::fflush(stdout);
  std::fprintf(stderr,
               "facecast: key %s for tenant %s (%s) stored in %s; this is the only time the key "
               "is shown\n",
               k.info.id.c_str(), k.info.tenant.c_str(), server::scope_names(scopes).c_str(),
               store.file().c_str());
}

void run_list(const ListArgs& a) {
  server::KeyStore store(store_path(a));
  const auto keys = store.list();
  if (a.json) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& k : keys)
      out.push_back({{"id", k.id},
                     {"tenant", k.tenant},
                     {"scopes", server::scope_names(k.scopes)},
                     {"created", k.created},
                     {"last_used", k.last_used},
                     {"revoked", k.revoked}});
    std::cout << out.dump(2) << '\n';
    return;
  }
  std::printf("%-12s  %-16s  %-44s  %-20s  %-20s  %s\n", "ID", "TENANT", "SCOPES", "CREATED",
              "LAST USED", "STATE");
  for (const auto& k : keys) {
    std::printf("%-12s  %-16s  %-44s  %-20s  %-20s  %s\n", k.id.c_str(), k.tenant.c_str(),
                server::scope_names(k.scopes).c_str(), iso_time(k.created).c_str(),
                iso_time(k.last_used).c_str(),
                k.revoked ? ("revoked " + iso_time(k.revoked)).c_str() : "active");
  }
}

void run_revoke(const RevokeArgs& a) {
  server::KeyStore store(store_path(a));
  if (!store.revoke(a.id))
    throw Error("keys revoke: no active key '" + a.id + "' (facecast keys list)",
                ErrorCode::kNotFound);
  std::fprintf(stderr,
               "facecast: key %s revoked (requests with it, and viewer tokens it made, get 401)\n",
               a.id.c_str());
}

}  // namespace

void add_keys_commands(CLI::App& app) {
  auto* keys = app.add_subcommand(
      "keys",
      "API keys of `facecast serve`: create, list, revoke (stored hashed in the data folder)");
  keys->require_subcommand(1);

  auto c = std::make_shared<CreateArgs>();
  auto* create = keys->add_subcommand("create", "Make a key and print it (once)");
  create->add_option("--tenant", c->tenant, "Whose key: rigs, jobs, uploads are kept per tenant")
      ->required();
  create
      ->add_option("--scopes", c->scopes,
                   "Comma-separated: speak, render, rigs:read, rigs:write, channels:produce, "
                   "channels:subscribe, metrics, admin")
      ->required();
  add_store_options(create, *c);
  create->callback([c] { run_create(*c); });

  auto l = std::make_shared<ListArgs>();
  auto* list = keys->add_subcommand("list", "Every key: id, tenant, scopes, created, last used");
  list->add_flag("--json", l->json, "JSON instead of a table");
  add_store_options(list, *l);
  list->callback([l] { run_list(*l); });

  auto r = std::make_shared<RevokeArgs>();
  auto* revoke = keys->add_subcommand("revoke", "Revoke a key at once (the store keeps its row)");
  revoke->add_option("id", r->id, "The key's id (facecast keys list)")->required();
  add_store_options(revoke, *r);
  revoke->callback([r] { run_revoke(*r); });
}

}  // namespace facecast::cli
