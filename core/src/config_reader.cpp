#include "facecast/core/config_reader.hpp"

#include "facecast/core/config.hpp"

namespace facecast {

ConfigReader ConfigReader::open(const std::filesystem::path& path) {
  return ConfigReader(load_json(path), path.string());
}

ConfigReader::ConfigReader(nlohmann::json object, std::string where)
    : object_(std::move(object)), file_(std::move(where)) {
  if (!object_.is_object()) throw Error(file_ + ": expected a JSON object");
}

const nlohmann::json* ConfigReader::find_raw(std::string_view key) const {
  const auto it = object_.find(key);
  return it == object_.end() ? nullptr : &*it;
}

const nlohmann::json* ConfigReader::find(std::string_view key) {
  const nlohmann::json* v = find_raw(key);
  if (v) used_.emplace(key);
  return v;
}

std::string ConfigReader::path_of(std::string_view key) const {
  return file_ + ": " + prefix_ + std::string(key);
}

ConfigReader& ConfigReader::section(std::string_view key) {
  nlohmann::json object = nlohmann::json::object();
  if (const nlohmann::json* v = find(key)) {
    if (!v->is_object()) fail(key, "expected an object");
    object = *v;
  }
  auto child = std::make_unique<ConfigReader>(std::move(object), file_);
  child->prefix_ = prefix_ + std::string(key) + ".";
  sections_.push_back(std::move(child));
  return *sections_.back();
}

namespace {
bool is_comment(const std::string& key) {
  return key.starts_with("_") || key == "description";
}
}  // namespace

std::vector<std::string> ConfigReader::keys() const {
  std::vector<std::string> out;
  for (const auto& [key, value] : object_.items())
    if (!is_comment(key)) out.push_back(key);
  return out;
}

void ConfigReader::reject_unknown() const {
  for (const auto& [key, value] : object_.items()) {
    if (is_comment(key) || used_.count(key)) continue;
    throw Error(file_ + ": unknown key '" + prefix_ + key + "'");
  }
  for (const auto& s : sections_) s->reject_unknown();
}

void ConfigReader::fail(std::string_view key, std::string_view what) const {
  throw Error(path_of(key) + ": " + std::string(what));
}

void ConfigReader::fail(std::string_view what) const {
  throw Error(file_ + ": " + (prefix_.empty() ? "" : prefix_.substr(0, prefix_.size() - 1) + ": ") +
              std::string(what));
}

}  // namespace facecast
