#pragma once
// Enum values by name: one table per enum gives both directions and the error listing the names.
#include <string>
#include <string_view>
#include <utility>

#include "facecast/core/error.hpp"

namespace facecast::viseme::detail {

template <class E, std::size_t N>
using NameTable = std::pair<std::string_view, E>[N];

/// The value named `name`; otherwise throws "unknown <what> '<name>' (a, b or c)".
template <class E, std::size_t N>
E parse_name(std::string_view name, const NameTable<E, N>& names, std::string_view what) {
  std::string listed;
  for (std::size_t i = 0; i < N; ++i) {
    if (names[i].first == name) return names[i].second;
    listed += (i == 0 ? "" : i + 1 == N ? " or " : ", ") + std::string(names[i].first);
  }
  throw Error("unknown " + std::string(what) + " '" + std::string(name) + "' (" + listed + ")");
}

/// The name of `value` (the first with that value); `fallback` when the table lacks it.
template <class E, std::size_t N>
std::string_view name_of(E value, const NameTable<E, N>& names, std::string_view fallback) {
  for (const auto& [n, v] : names)
    if (v == value) return n;
  return fallback;
}

}  // namespace facecast::viseme::detail
