// Mapping: viseme channels and expressions -> a rig's blendshapes, from the tables in
// configs/anim/.
#include <algorithm>
#include <map>

#include "facecast/anim/animation.hpp"
#include "facecast/core/config.hpp"
#include "facecast/core/config_reader.hpp"
#include "facecast/core/error.hpp"

namespace facecast::anim {
namespace {

using viseme::VisemeSet;

int set_index(VisemeSet set) {
  return static_cast<int>(set);
}

// Rig shapes that a table name drives: the name itself; else Left/Right -> _L/_R (ICT FaceKit);
// else an unsided name split over name_L and name_R.
std::vector<int> resolve(const std::vector<std::string>& shapes, const std::string& name) {
  const auto find = [&](const std::string& n) {
    const auto it = std::find(shapes.begin(), shapes.end(), n);
    return it == shapes.end() ? -1 : static_cast<int>(it - shapes.begin());
  };
  if (const int i = find(name); i >= 0) return {i};
  for (const auto& [side, suffix] : {std::pair{"Left", "_L"}, std::pair{"Right", "_R"}}) {
    const std::string s = side;
    if (name.size() > s.size() && name.ends_with(s)) {
      const int i = find(name.substr(0, name.size() - s.size()) + suffix);
      return i >= 0 ? std::vector<int>{i} : std::vector<int>{};
    }
  }
  std::vector<int> out;
  for (const char* suffix : {"_L", "_R"})
    if (const int i = find(name + suffix); i >= 0) out.push_back(i);
  return out;
}

// The row `key` of `table` (an object of shape name -> weight) resolved against the rig's shapes.
std::vector<Mapping::Entry> read_row(const std::vector<std::string>& shapes, ConfigReader& table,
                                     const std::string& key) {
  nlohmann::json row;
  table.require(key, row);
  if (!row.is_object()) table.fail(key, "expected an object of shape weights");
  std::vector<Mapping::Entry> out;
  for (const auto& [name, w] : row.items()) {
    if (!w.is_number()) table.fail(key + "." + name, "expected a number");
    for (const int s : resolve(shapes, name)) out.push_back({s, w.get<float>()});
  }
  return out;
}

// The keys of the object `key`, which section(key) has checked (for tables keyed by names the
// code does not know in advance).
std::vector<std::string> keys_of(ConfigReader& table, const std::string& key) {
  nlohmann::json object;
  table.require(key, object);
  std::vector<std::string> out;
  for (const auto& [name, value] : object.items()) out.push_back(name);
  return out;
}

}  // namespace

Mapping Mapping::for_rig(const std::vector<std::string>& shape_names) {
  Mapping m;
  m.shapes_ = shape_names;
  const auto has_oculus = std::count_if(shape_names.begin(), shape_names.end(),
                                        [](auto& n) { return n.starts_with("viseme_"); }) >= 10;
  m.table_ = has_oculus ? "oculus" : "arkit";

  // Viseme names per set; MPEG-4 rows are the Oculus rows renamed. (The viseme module owns and
  // checks this file; only the keys read here are used.)
  ConfigReader sets = ConfigReader::open(config_path("viseme/viseme_sets.json"));
  std::map<std::string, std::string> mpeg4_from_oculus;
  sets.require("zh15", m.set_names_[set_index(VisemeSet::kZh15)])
      .require("oculus", m.set_names_[set_index(VisemeSet::kOculus)]);
  ConfigReader& renamed = sets.section("mpeg4_from_oculus");
  for (const auto& oc : m.set_names_[set_index(VisemeSet::kOculus)]) {
    std::string name;
    renamed.require(oc, name);
    m.set_names_[set_index(VisemeSet::kMpeg4)].push_back(name);
  }

  const auto table_path = config_path("anim/visemes_" + m.table_ + ".json");
  ConfigReader table = ConfigReader::open(table_path);
  size_t mapped = 0;
  ConfigReader& visemes = table.section("visemes");
  ConfigReader& closure = table.section("closure");
  for (const VisemeSet set : {VisemeSet::kZh15, VisemeSet::kOculus}) {
    const std::string set_name(viseme::to_string(set));
    const auto& names = m.set_names_[set_index(set)];
    ConfigReader& rows = visemes.section(set_name);
    for (const auto& v : names) {
      m.sets_[set_index(set)].push_back(read_row(shape_names, rows, v));
      mapped += m.sets_[set_index(set)].back().size();
    }
    std::vector<std::string> closing;
    closure.require(set_name, closing);
    for (const auto& v : closing) {
      const auto it = std::find(names.begin(), names.end(), v);
      if (it == names.end()) closure.fail(set_name, "'" + v + "' is not a viseme of the set");
      m.closure_[set_index(set)].push_back(static_cast<int>(it - names.begin()));
    }
  }
  m.sets_[set_index(VisemeSet::kMpeg4)] = m.sets_[set_index(VisemeSet::kOculus)];
  m.closure_[set_index(VisemeSet::kMpeg4)] = m.closure_[set_index(VisemeSet::kOculus)];
  if (mapped == 0)
    throw Error("the rig has no blendshape that " + table_path.string() +
                    " maps a viseme to (expected ARKit names or Oculus viseme_* morphs)",
                ErrorCode::kUnsupported);
  std::vector<std::string> damped;
  table.require("closure_damped", damped);
  for (const auto& name : damped)
    for (const int s : resolve(shape_names, name)) m.closure_damped_.push_back(s);
  table.reject_unknown();

  ConfigReader expressions = ConfigReader::open(config_path("anim/expressions_arkit.json"));
  ConfigReader& rows = expressions.section("expressions");
  for (const auto& name : keys_of(expressions, "expressions"))
    m.expressions_.emplace_back(name, read_row(shape_names, rows, name));
  expressions.reject_unknown();

  const auto one = [&](const std::string& n) {
    const auto r = resolve(shape_names, n);
    return r.empty() ? -1 : r.front();
  };
  m.blink_left = one("eyeBlinkLeft");
  m.blink_right = one("eyeBlinkRight");
  const char* sides[2] = {"Left", "Right"};
  for (int s = 0; s < 2; ++s) {
    m.look_up[s] = one(std::string("eyeLookUp") + sides[s]);
    m.look_down[s] = one(std::string("eyeLookDown") + sides[s]);
    m.look_in[s] = one(std::string("eyeLookIn") + sides[s]);
    m.look_out[s] = one(std::string("eyeLookOut") + sides[s]);
  }
  return m;
}

const std::vector<std::vector<Mapping::Entry>>& Mapping::visemes(VisemeSet set) const {
  return sets_[set_index(set)];
}
const std::vector<std::string>& Mapping::viseme_names(VisemeSet set) const {
  return set_names_[set_index(set)];
}
const std::vector<int>& Mapping::closure_channels(VisemeSet set) const {
  return closure_[set_index(set)];
}
const std::vector<Mapping::Entry>* Mapping::expression(const std::string& name) const {
  for (const auto& [n, row] : expressions_)
    if (n == name) return &row;
  return nullptr;
}

}  // namespace facecast::anim
