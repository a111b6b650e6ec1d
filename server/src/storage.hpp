#pragma once
// What tenants keep on the server's disk: their stored rigs and their jobs' files (videos),
// bounded per tenant by tenant_disk_quota, and rigs removed rig_retention seconds after they were
// stored (videos expire with their jobs, job_retention). docs/security.md, "Quotas".
#include <cstdint>
#include <string>

#include "facecast/server/options.hpp"
#include "jobs.hpp"
#include "rigs.hpp"

namespace facecast::server {

class Storage {
 public:
  Storage(const ServerOptions& options, RigRegistry& rigs, Jobs& jobs)
      : options_(options), rigs_(rigs), jobs_(jobs) {}

  /// Bytes `tenant`'s stored rigs and job files take (a folder scan and a job query: call it off
  /// the I/O threads).
  std::uint64_t tenant_usage(const std::string& tenant) const;

  /// Throws RequestError (limit, 413) when `tenant` would store more than tenant_disk_quota with
  /// `adding` more bytes; nothing when the quota is 0 (off).
  void check_quota(const std::string& tenant, std::uint64_t adding = 0) const;

  /// Removes the stored rigs created more than rig_retention seconds ago (not the built-in ones,
  /// not the server's default_rig); nothing when rig_retention is 0. Returns how many.
  int expire_rigs();

 private:
  const ServerOptions& options_;
  RigRegistry& rigs_;
  Jobs& jobs_;
};

}  // namespace facecast::server
