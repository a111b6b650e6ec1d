// Weights by shape name, as the command line gives them ("jawOpen=0.7, eyeBlinkLeft=1").
#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "facecast/core/error.hpp"
#include "facecast/render/renderer.hpp"

namespace facecast::render {

std::vector<std::pair<std::string, float>> parse_weight_list(std::string_view text) {
  std::vector<std::pair<std::string, float>> out;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t comma = std::min(text.find(',', pos), text.size());
    std::string item(text.substr(pos, comma - pos));
    pos = comma + 1;
    const auto trim = [](std::string s) {
      const auto b = s.find_first_not_of(" \t"), e = s.find_last_not_of(" \t");
      return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
    };
    item = trim(item);
    if (item.empty()) {
      if (comma == text.size()) break;
      continue;
    }
    const std::size_t eq = item.find('=');
    if (eq == std::string::npos) throw Error("weights: '" + item + "' is not name=value");
    const std::string name = trim(item.substr(0, eq)), value = trim(item.substr(eq + 1));
    char* end = nullptr;
    const float v = std::strtof(value.c_str(), &end);
    if (name.empty() || value.empty() || *end != '\0' || !std::isfinite(v))
      throw Error("weights: '" + item + "' is not name=value with a number");
    out.emplace_back(name, v);
  }
  return out;
}

std::vector<float> weights_for(const rig::Rig& rig,
                               const std::vector<std::pair<std::string, float>>& named) {
  std::vector<float> w(rig.shapes.size(), 0.0f);
  for (const auto& [name, value] : named) {
    const int s = rig.find_shape(name);
    if (s < 0)
      throw Error("weights: the rig has no shape named '" + name + "'", ErrorCode::kNotFound);
    w[static_cast<std::size_t>(s)] = value;
  }
  return w;
}

}  // namespace facecast::render
