#pragma once
// What tenants keep on the server's disk: their stored rigs and their jobs' files (videos),
// bounded per tenant by tenant_disk_quota, and rigs removed rig_retention seconds after they were
// stored (videos expire with their jobs, job_retention). docs/security.md, "Quotas".
#include <cstdint>
#include <string>

#include "state.hpp"

namespace facecast::server {

/// Bytes `tenant`'s stored rigs and job files take (a folder scan and a job query: call it off
/// the I/O threads).
std::uint64_t tenant_disk_usage(State& state, const std::string& tenant);

/// Throws RequestError (limit, 413) when `tenant` would store more than tenant_disk_quota with
/// `adding` more bytes; nothing when the quota is 0 (off).
void check_disk_quota(State& state, const std::string& tenant, std::uint64_t adding = 0);

/// Removes the stored rigs created more than rig_retention seconds ago (not the built-in ones,
/// not the server's default_rig); nothing when rig_retention is 0. Returns how many.
int expire_rigs(State& state);

}  // namespace facecast::server
