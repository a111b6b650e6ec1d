#include "facecast/core/config.hpp"

#include <cstdlib>

#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/core/install.hpp"

namespace facecast {

std::filesystem::path config_dir() {
  if (const char* env = std::getenv("FACECAST_CONFIG_DIR"); env && *env) return env;
  if (const auto share = installed_share_dir(); !share.empty()) return share / "configs";
  return FACECAST_DEFAULT_CONFIG_DIR;
}

std::filesystem::path config_path(const std::filesystem::path& relative) {
  auto p = config_dir() / relative;
  if (!std::filesystem::exists(p))
    throw Error(p.string() + ": config file not found", ErrorCode::kNotFound);
  return p;
}

nlohmann::json load_json(const std::filesystem::path& path) {
  const std::string text = read_file(path);
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // Translate the byte offset into line:column for the message.
    std::size_t line = 1, col = 1;
    for (std::size_t i = 0; i + 1 < e.byte && i < text.size(); ++i) {
      if (text[i] == '\n') {
        ++line;
        col = 1;
      } else {
        ++col;
      }
    }
    throw Error(path.string() + ":" + std::to_string(line) + ":" + std::to_string(col) +
                ": invalid JSON");
  } catch (const nlohmann::json::exception&) {  // out_of_range: a number too large for a double
    throw Error(path.string() + ": invalid JSON: a number is out of range");
  }
}

std::filesystem::path shared_data_dir() {
  if (const char* env = std::getenv("FACECAST_SHARED_DATA"); env && *env) return env;
  return FACECAST_DEFAULT_SHARED_DATA;
}

}  // namespace facecast
