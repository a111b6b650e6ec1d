#pragma once
// Locations of configs/ and of the shared real-data folder, and JSON config loading.
#include <filesystem>

#include <nlohmann/json.hpp>

namespace facecast {

/// configs/ of this build: $FACECAST_CONFIG_DIR if set, else the source tree's configs/.
std::filesystem::path config_dir();

/// A path under config_dir(); throws Error(kNotFound) when it does not exist.
std::filesystem::path config_path(const std::filesystem::path& relative);

/// Parses a JSON file; errors name the file, line and column.
nlohmann::json load_json(const std::filesystem::path& path);

/// The shared real-data folder (../shared/data): $FACECAST_SHARED_DATA if set, else the configured
/// one.
std::filesystem::path shared_data_dir();

}  // namespace facecast
