#include "facecast/core/install.hpp"

#include <system_error>

namespace facecast {

std::filesystem::path installed_share_dir() {
  static const std::filesystem::path dir = [] {
    std::error_code ec;
    const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
    if (ec || exe.empty()) return std::filesystem::path();
    auto share = exe.parent_path().parent_path() / "share" / "facecast";
    if (!std::filesystem::is_directory(share / "configs", ec)) return std::filesystem::path();
    return share;
  }();
  return dir;
}

}  // namespace facecast
