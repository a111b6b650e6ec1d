#include "storage.hpp"

#include <cstdio>

#include "clock.hpp"
#include "log.hpp"

namespace facecast::server {

namespace fs = std::filesystem;

namespace {

std::uint64_t size_of(const fs::path& path) {
  std::error_code ec;
  if (fs::is_regular_file(path, ec)) return fs::file_size(path, ec);
  std::uint64_t total = 0;
  for (fs::recursive_directory_iterator it(path, ec), end; !ec && it != end; it.increment(ec))
    if (it->is_regular_file(ec)) total += it->file_size(ec);
  return total;
}

std::string megabytes(std::uint64_t bytes) {
  char out[32];
  std::snprintf(out, sizeof out, "%.1f MB", static_cast<double>(bytes) / 1e6);
  return out;
}

}  // namespace

std::uint64_t Storage::tenant_usage(const std::string& tenant) const {
  std::uint64_t total = 0;
  for (const RigInfo& r : rigs_.list())
    if (!r.builtin && r.tenant == tenant) total += size_of(rigs_.glb_path(r.id).parent_path());
  for (const fs::path& f : jobs_.tenant_files(tenant)) total += size_of(f);
  return total;
}

void Storage::check_quota(const std::string& tenant, std::uint64_t adding) const {
  const std::uint64_t quota = options_.tenant_disk_quota;
  if (quota == 0) return;
  const std::uint64_t used = tenant_usage(tenant);
  // Something to add must fit; a job asked for (nothing known yet) needs room left.
  if (adding > 0 ? used + adding <= quota : used < quota) return;
  throw RequestError(Code::kLimit,
                     "tenant '" + tenant + "' stores " + megabytes(used) +
                         (adding ? " and would add " + megabytes(adding) : "") + " of its " +
                         megabytes(quota) + " (tenant_disk_quota): delete rigs or jobs first",
                     413);
}

int Storage::expire_rigs() {
  const double retention = options_.rig_retention;
  if (retention <= 0) return 0;
  const double before = unix_now() - retention;
  int removed = 0;
  for (const RigInfo& r : rigs_.list()) {
    if (r.builtin || r.id == options_.default_rig || r.created <= 0 || r.created >= before)
      continue;
    try {
      if (rigs_.remove(r.id)) {
        ++removed;
        log::info("rig_expired", {{"rig", r.id}, {"tenant", r.tenant}});
      }
    } catch (const std::exception& e) {
      log::warn("rig_expire_failed", {{"rig", r.id}, {"error", e.what()}});
    }
  }
  return removed;
}

}  // namespace facecast::server
