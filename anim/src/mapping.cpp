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

// The viseme table by what the avatar has: Oculus visemes (10 or more viseme_* shapes); ARKit
// names (jawOpen, or the ICT FaceKit's); VRM presets (3 or more of aa ih ou ee oh); else ARKit.
std::string choose_table(const std::vector<std::string>& shapes) {
  const auto has_oculus = std::count_if(shapes.begin(), shapes.end(),
                                        [](auto& n) { return n.starts_with("viseme_"); }) >= 10;
  if (has_oculus) return "oculus";
  if (!resolve(shapes, "jawOpen").empty()) return "arkit";
  int vrm = 0;
  for (const char* n : {"aa", "ih", "ou", "ee", "oh"})
    vrm += std::find(shapes.begin(), shapes.end(), n) != shapes.end();
  return vrm >= 3 ? "vrm" : "arkit";
}

// The first of `names` the rig has (resolved as table names are), or -1.
int first_of(const std::vector<std::string>& shapes, std::initializer_list<std::string> names) {
  for (const auto& n : names)
    if (const auto r = resolve(shapes, n); !r.empty()) return r.front();
  return -1;
}

}  // namespace

Mapping Mapping::for_rig(const std::vector<std::string>& shape_names) {
  Mapping m;
  m.shapes_ = shape_names;
  m.table_ = choose_table(shape_names);

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
    throw Error(
        "the rig has no blendshape that " + table_path.string() +
            " maps a viseme to (expected ARKit names, Oculus viseme_* morphs or VRM presets)",
        ErrorCode::kUnsupported);
  std::vector<std::string> damped;
  table.require("closure_damped", damped);
  for (const auto& name : damped)
    for (const int s : resolve(shape_names, name)) m.closure_damped_.push_back(s);
  table.reject_unknown();

  ConfigReader expressions = ConfigReader::open(
      config_path(m.table_ == "vrm" ? "anim/expressions_vrm.json" : "anim/expressions_arkit.json"));
  ConfigReader& rows = expressions.section("expressions");
  for (const auto& name : keys_of(expressions, "expressions"))
    m.expressions_.emplace_back(name, read_row(shape_names, rows, name));
  expressions.reject_unknown();

  // ARKit names first, then VRM presets (one blink or look shape for both eyes).
  m.blink_left = first_of(shape_names, {"eyeBlinkLeft", "blinkLeft", "blink"});
  m.blink_right = first_of(shape_names, {"eyeBlinkRight", "blinkRight", "blink"});
  const std::string sides[2] = {"Left", "Right"};
  // The subject's left eye looks in (towards the nose) when the gaze goes to the subject's right.
  const std::string in_vrm[2] = {"lookRight", "lookLeft"}, out_vrm[2] = {"lookLeft", "lookRight"};
  for (int s = 0; s < 2; ++s) {
    m.look_up[s] = first_of(shape_names, {"eyeLookUp" + sides[s], "lookUp"});
    m.look_down[s] = first_of(shape_names, {"eyeLookDown" + sides[s], "lookDown"});
    m.look_in[s] = first_of(shape_names, {"eyeLookIn" + sides[s], in_vrm[s]});
    m.look_out[s] = first_of(shape_names, {"eyeLookOut" + sides[s], out_vrm[s]});
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
std::vector<Mapping::Channel> Mapping::channels() const {
  std::vector<Channel> out;
  for (const VisemeSet set : {VisemeSet::kZh15, VisemeSet::kOculus}) {
    const auto& names = set_names_[set_index(set)];
    for (std::size_t v = 0; v < names.size(); ++v)
      out.push_back({"viseme." + std::string(viseme::to_string(set)) + "." + names[v],
                     names[v] == "sil" || !sets_[set_index(set)][v].empty()});
  }
  for (const auto& [name, row] : expressions_)
    out.push_back({"expression." + name, name == "neutral" || !row.empty()});
  out.push_back({"blink", blink_left >= 0 && blink_right >= 0});
  out.push_back({"eye_look", look_up[0] >= 0 || look_in[0] >= 0 || look_out[0] >= 0});
  return out;
}

const std::vector<Mapping::Entry>* Mapping::expression(const std::string& name) const {
  for (const auto& [n, row] : expressions_)
    if (n == name) return &row;
  return nullptr;
}

}  // namespace facecast::anim
