#pragma once
// An utterance's visemes as one string of names ("PP aa sil"), for compact expectations.
#include <string>

#include "facecast/viseme/viseme.hpp"

namespace facecast::test {

inline std::string visemes(const viseme::Utterance& u) {
  std::string s;
  for (const auto& v : u.visemes) s += (s.empty() ? "" : " ") + v.viseme;
  return s;
}

}  // namespace facecast::test
