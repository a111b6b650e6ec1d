#pragma once
// Structured logs: one line per event on stderr, logfmt style, with ids:
//   2026-11-22T03:04:05.678Z info ws_open conn=c7 remote=127.0.0.1:50412
#include <atomic>
#include <cstdint>
#include <initializer_list>
#include <string>
#include <string_view>
#include <variant>

namespace facecast::server::log {

enum class Level { kDebug = 0, kInfo = 1, kWarn = 2, kError = 3 };

void set_level(std::string_view name);  // debug | info | warn | error
bool enabled(Level level) noexcept;

// std::monostate: the field is left out of the line.
using Value = std::variant<std::monostate, std::string_view, std::string, const char*, long long,
                           double, bool>;
struct Field {
  std::string_view key;
  Value value;
  /// A field written only when `v` is not empty (e.g. headers that only proxies add).
  static Field if_set(std::string_view k, std::string_view v) {
    Field f(k, v);
    if (v.empty()) f.value = std::monostate{};
    return f;
  }
  Field(std::string_view k, std::string_view v) : key(k), value(v) {}
  Field(std::string_view k, const std::string& v) : key(k), value(std::string_view(v)) {}
  Field(std::string_view k, const char* v) : key(k), value(v) {}
  Field(std::string_view k, double v) : key(k), value(v) {}
  Field(std::string_view k, bool v) : key(k), value(v) {}
  template <class I>
  requires std::is_integral_v<I> Field(std::string_view k, I v)
      : key(k), value(static_cast<long long>(v)) {}
};

void write(Level level, std::string_view event, std::initializer_list<Field> fields);

inline void debug(std::string_view event, std::initializer_list<Field> fields = {}) {
  if (enabled(Level::kDebug)) write(Level::kDebug, event, fields);
}
inline void info(std::string_view event, std::initializer_list<Field> fields = {}) {
  if (enabled(Level::kInfo)) write(Level::kInfo, event, fields);
}
inline void warn(std::string_view event, std::initializer_list<Field> fields = {}) {
  if (enabled(Level::kWarn)) write(Level::kWarn, event, fields);
}
inline void error(std::string_view event, std::initializer_list<Field> fields = {}) {
  if (enabled(Level::kError)) write(Level::kError, event, fields);
}

}  // namespace facecast::server::log
