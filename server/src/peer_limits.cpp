#include "peer_limits.hpp"

#include <algorithm>

namespace facecast::server {

ClientAddresses::ClientAddresses(int max_per_address,
                                 const std::vector<std::string>& trusted_proxies)
    : max_(max_per_address) {
  for (const auto& p : trusted_proxies) trusted_.push_back(net::ip::make_address(p));
}

bool ClientAddresses::trusted(const net::ip::address& peer) const {
  const auto same = [&](const net::ip::address& a) {
    if (a == peer) return true;
    // An IPv4 proxy seen on a dual-stack socket as ::ffff:a.b.c.d.
    return peer.is_v6() && peer.to_v6().is_v4_mapped() && a.is_v4() &&
           net::ip::make_address_v4(net::ip::v4_mapped, peer.to_v6()) == a.to_v4();
  };
  return std::any_of(trusted_.begin(), trusted_.end(), same);
}

std::string ClientAddresses::client(const net::ip::address& peer,
                                    std::string_view forwarded_for) const {
  if (!trusted(peer)) return peer.to_string();
  // Right to left: the first address that is not one of our proxies is the client.
  while (!forwarded_for.empty()) {
    const auto comma = forwarded_for.rfind(',');
    std::string_view item =
        comma == std::string_view::npos ? forwarded_for : forwarded_for.substr(comma + 1);
    forwarded_for =
        comma == std::string_view::npos ? std::string_view{} : forwarded_for.substr(0, comma);
    while (!item.empty() && (item.front() == ' ' || item.front() == '\t')) item.remove_prefix(1);
    while (!item.empty() && (item.back() == ' ' || item.back() == '\t')) item.remove_suffix(1);
    boost::system::error_code ec;
    const auto a = net::ip::make_address(std::string(item), ec);
    if (ec) return "";  // a malformed header: count the proxy's own connection only
    if (!trusted(a)) return a.to_string();
  }
  return "";
}

ClientAddresses::Hold ClientAddresses::hold(const std::string& address) {
  {
    const std::lock_guard lock(mutex_);
    int& n = open_[address];
    if (n >= max_) return nullptr;
    ++n;
  }
  return Hold(this, [this, address](void*) {
    const std::lock_guard lock(mutex_);
    const auto it = open_.find(address);
    if (it != open_.end() && --it->second <= 0) open_.erase(it);
  });
}

int ClientAddresses::count(const std::string& address) {
  const std::lock_guard lock(mutex_);
  const auto it = open_.find(address);
  return it == open_.end() ? 0 : it->second;
}

std::shared_ptr<void> BodyMemory::reserve(std::size_t bytes) {
  std::size_t held = held_.load();
  do {
    if (bytes > budget_ - std::min(held, budget_)) return nullptr;
  } while (!held_.compare_exchange_weak(held, held + bytes));
  return std::shared_ptr<void>(this, [this, bytes](void*) { held_.fetch_sub(bytes); });
}

}  // namespace facecast::server
