#pragma once
// The one typed reader of Facecast's JSON configs (configs/**.json and user config files).
//
// Every field is read into a value that already holds its default (the option structs' defaults,
// mirrored in configs/), so a file may leave keys out; a key that is present must have the right
// type, and a key nobody reads is an error (a typo is never silently ignored). "description" and
// keys starting with '_' are comments. Every error is one line naming the file and the key path:
//
//   configs/server.json: port: expected an integer
//   configs/rigbuild/build.json: contacts.rounds: expected a whole number in 0..2147483647
//   configs/server.json: unknown key 'prot'
//
//   ConfigReader c = ConfigReader::open(config_path("render/render.json"));
//   c.read("width", o.width).read("height", o.height);
//   ConfigReader& video = c.section("video");
//   video.read("fps", v.fps);
//   c.reject_unknown();  // also checks the sections
#include <array>
#include <cmath>
#include <filesystem>
#include <initializer_list>
#include <limits>
#include <memory>
#include <set>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "facecast/core/error.hpp"

namespace facecast {

class ConfigReader {
 public:
  /// Parses `path` (errors name the file, line and column); it must hold a JSON object.
  static ConfigReader open(const std::filesystem::path& path);

  /// Reads an object already parsed; `where` names it in errors ("file" or "file: key").
  ConfigReader(nlohmann::json object, std::string where);

  /// When `key` is present, converts it into `value` (type-checked; integers must be whole and
  /// fit); otherwise `value` keeps its default.
  template <class T>
  ConfigReader& read(std::string_view key, T& value) {
    if (const nlohmann::json* v = find(key)) value = convert<T>(*v, path_of(key));
    return *this;
  }

  /// Like read(), but a missing key is an error.
  template <class T>
  ConfigReader& require(std::string_view key, T& value) {
    if (!find(key)) fail(key, "missing");
    return read(key, value);
  }

  /// Reads a string that must be one of `choices` (name, value) into `value`.
  template <class E>
  ConfigReader& read_choice(std::string_view key, E& value,
                            std::initializer_list<std::pair<std::string_view, E>> choices) {
    const nlohmann::json* v = find(key);
    if (!v) return *this;
    const auto name = convert<std::string>(*v, path_of(key));
    std::string listed;
    for (const auto& [n, e] : choices) {
      if (n == name) {
        value = e;
        return *this;
      }
      listed += (listed.empty() ? "" : ", ") + std::string(n);
    }
    fail(key, "'" + name + "' is not one of " + listed);
  }

  /// The nested object `key` (an empty one when absent); its keys are checked by reject_unknown().
  ConfigReader& section(std::string_view key);

  bool has(std::string_view key) const { return find_raw(key) != nullptr; }
  /// The keys of this object that are not comments, in file order (for maps keyed by name).
  std::vector<std::string> keys() const;

  /// Throws naming the first key (here or in a section) that nobody read.
  void reject_unknown() const;

  /// Throws "<where>: <key path>: <what>".
  [[noreturn]] void fail(std::string_view key, std::string_view what) const;

  /// Throws "<where>: <what>" (for checks across several keys).
  [[noreturn]] void fail(std::string_view what) const;

 private:
  const nlohmann::json* find(std::string_view key);
  const nlohmann::json* find_raw(std::string_view key) const;
  std::string path_of(std::string_view key) const;

  template <class T>
  static T convert(const nlohmann::json& v, const std::string& where);

  nlohmann::json object_;
  std::string file_;    // the file, for messages
  std::string prefix_;  // "" or "section." for nested readers
  std::set<std::string, std::less<>> used_;
  std::vector<std::unique_ptr<ConfigReader>> sections_;
};

namespace config_detail {
template <class T>
struct is_vector : std::false_type {};
template <class T, class A>
struct is_vector<std::vector<T, A>> : std::true_type {};
template <class T>
struct is_array : std::false_type {};
template <class T, std::size_t N>
struct is_array<std::array<T, N>> : std::true_type {};
}  // namespace config_detail

template <class T>
T ConfigReader::convert(const nlohmann::json& v, const std::string& where) {
  const auto bad = [&](std::string_view what) -> Error {
    return Error(where + ": " + std::string(what));
  };
  if constexpr (std::is_same_v<T, bool>) {
    if (!v.is_boolean()) throw bad("expected true or false");
    return v.get<bool>();
  } else if constexpr (std::is_integral_v<T>) {
    if (!v.is_number()) throw bad("expected an integer");
    const double x = v.get<double>();
    if (x != std::floor(x) || x < static_cast<double>(std::numeric_limits<T>::min()) ||
        x > static_cast<double>(std::numeric_limits<T>::max()))
      throw bad("expected a whole number in " + std::to_string(std::numeric_limits<T>::min()) +
                ".." + std::to_string(std::numeric_limits<T>::max()));
    return v.is_number_float() ? static_cast<T>(x) : v.get<T>();
  } else if constexpr (std::is_floating_point_v<T>) {
    if (!v.is_number()) throw bad("expected a number");
    return v.get<T>();
  } else if constexpr (std::is_same_v<T, std::string> || std::is_same_v<T, std::filesystem::path>) {
    if (!v.is_string()) throw bad("expected a string");
    return T(v.get<std::string>());
  } else if constexpr (std::is_same_v<T, nlohmann::json>) {
    return v;
  } else if constexpr (config_detail::is_vector<T>::value) {
    if (!v.is_array()) throw bad("expected an array");
    T out;
    for (std::size_t i = 0; i < v.size(); ++i)
      out.push_back(convert<typename T::value_type>(v[i], where + "[" + std::to_string(i) + "]"));
    return out;
  } else if constexpr (config_detail::is_array<T>::value) {
    if (!v.is_array() || v.size() != std::tuple_size_v<T>)
      throw bad("expected an array of " + std::to_string(std::tuple_size_v<T>));
    T out{};
    for (std::size_t i = 0; i < out.size(); ++i)
      out[i] = convert<typename T::value_type>(v[i], where + "[" + std::to_string(i) + "]");
    return out;
  } else {
    static_assert(sizeof(T) == 0, "ConfigReader: unsupported field type");
  }
}

}  // namespace facecast
