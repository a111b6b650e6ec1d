// facecast rig pack | unpack | info
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>

#include "facecast/anim/animation.hpp"
#include "facecast/app/commands.hpp"
#include "facecast/core/error.hpp"
#include "facecast/rig/avatar_view.hpp"
#include "facecast/rig/rig_io.hpp"

namespace facecast::cli {
namespace {

struct PackArgs {
  std::string neutral, shapes, out;
  std::vector<std::string> exclude{"identity*"};
};

struct InfoArgs {
  std::string rig;
  bool json = false;
};

struct UnpackArgs {
  std::string rig, out;
};

// The face view of a glTF avatar with the meshes it came from (none listed for an OBJ).
struct Loaded {
  rig::Rig rig;
  std::vector<rig::ViewMesh> meshes;
};

Loaded load_for_info(const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  if (ext != ".glb" && ext != ".gltf" && ext != ".vrm") return {rig::load_rig(path), {}};
  rig::AvatarView view = rig::make_view(rig::AvatarDocument::read(path));
  return {std::move(view.rig), std::move(view.meshes)};
}

// Which channels (visemes, expressions, blink, eye look) the avatar can show and which not.
nlohmann::json channel_report(const rig::Rig& rig) {
  nlohmann::json j = {
      {"table", "none"}, {"shown", nlohmann::json::array()}, {"missing", nlohmann::json::array()}};
  try {
    const auto mapping = anim::Mapping::for_rig(rig.shape_names());
    j["table"] = mapping.table();
    for (const auto& c : mapping.channels()) j[c.shown ? "shown" : "missing"].push_back(c.name);
  } catch (const Error& e) {
    j["error"] = e.what();  // not a face rig: nothing maps
  }
  return j;
}

void print_info(const Loaded& loaded, bool as_json) {
  const rig::Rig& rig = loaded.rig;
  const auto comps = rig::connected_components(rig.vertex_count(), rig.triangles);
  const nlohmann::json channels = channel_report(rig);
  if (as_json) {
    nlohmann::json j;
    j["vertices"] = rig.vertex_count();
    j["meshes"] = nlohmann::json::array();
    for (const auto& m : loaded.meshes)
      j["meshes"].push_back({{"name", m.name}, {"vertices", m.vertices}, {"targets", m.targets}});
    j["channels"] = channels;
    j["triangles"] = rig.triangle_count();
    j["components"] = comps.count;
    for (const auto& m : rig.materials) j["materials"].push_back(m.name);
    j["shapes"] = nlohmann::json::array();
    for (const auto& s : rig.shapes) {
      j["shapes"].push_back({{"name", s.name},
                             {"max_displacement", s.max_displacement()},
                             {"vertices_moved", s.vertices.size()}});
    }
    for (const auto& l : rig.landmarks)
      j["landmarks"].push_back({{"name", l.name}, {"vertex", l.vertex}});
    std::cout << j.dump(2) << '\n';
    return;
  }
  std::cout << "vertices    " << rig.vertex_count() << '\n'
            << "triangles   " << rig.triangle_count() << '\n'
            << "components  " << comps.count << '\n'
            << "materials   " << rig.materials.size() << ":";
  for (const auto& m : rig.materials) std::cout << ' ' << m.name;
  std::cout << "\nlandmarks   " << rig.landmarks.size() << "\nshapes      " << rig.shapes.size()
            << "\n  " << std::left << std::setw(24) << "name" << std::right << std::setw(16)
            << "max displacement" << std::setw(10) << "moved" << '\n';
  for (const auto& s : rig.shapes) {
    std::cout << "  " << std::left << std::setw(24) << s.name << std::right << std::setw(16)
              << std::setprecision(5) << s.max_displacement() << std::setw(10) << s.vertices.size()
              << '\n';
  }
  for (const auto& m : loaded.meshes)
    std::cout << "mesh        " << m.name << ": " << m.vertices << " vertices, " << m.targets.size()
              << " targets\n";
  std::cout << "channels    " << channels["table"].get<std::string>() << " table, "
            << channels["shown"].size() << " shown, " << channels["missing"].size() << " missing:";
  for (const auto& c : channels["missing"]) std::cout << ' ' << c.get<std::string>();
  std::cout << '\n';
}

}  // namespace

void add_rig_commands(CLI::App& app) {
  auto* rig =
      app.add_subcommand("rig", "Pack, unpack and inspect rigs (neutral mesh + blendshapes)");
  rig->require_subcommand(1);

  auto pack = std::make_shared<PackArgs>();
  auto* p = rig->add_subcommand("pack", "Pack a neutral OBJ and a folder of shape OBJs into a GLB");
  p->add_option("--neutral", pack->neutral, "Neutral mesh (OBJ)")
      ->required()
      ->check(CLI::ExistingFile);
  p->add_option(
       "--shapes", pack->shapes,
       "Folder of shape OBJs with the neutral's vertex count; each is named by its file stem")
      ->required()
      ->check(CLI::ExistingDirectory);
  p->add_option("--out", pack->out, "Output GLB")->required();
  p->add_option("--exclude", pack->exclude,
                "File-stem patterns to skip (default: identity*, the ICT FaceKit identity modes)")
      ->capture_default_str();
  p->callback([pack] {
    std::cerr << "reading " << pack->neutral << " and shapes in " << pack->shapes << "...\n";
    const rig::Rig r = rig::read_obj_shapes(pack->neutral, pack->shapes, pack->exclude);
    rig::write_glb(pack->out, r);
    std::cerr << "wrote " << pack->out << ": " << r.vertex_count() << " vertices, "
              << r.triangle_count() << " triangles, " << r.shapes.size() << " shapes\n";
  });

  auto unpack = std::make_shared<UnpackArgs>();
  auto* u = rig->add_subcommand("unpack", "Write a GLB rig as neutral.obj plus one OBJ per shape");
  u->add_option("rig", unpack->rig, "Rig (GLB)")->required()->check(CLI::ExistingFile);
  u->add_option("--out", unpack->out, "Output folder")->required();
  u->callback([unpack] {
    const rig::Rig r = rig::load_rig(unpack->rig);
    rig::write_obj_folder(unpack->out, r);
    std::cerr << "wrote neutral.obj and " << r.shapes.size() << " shapes to " << unpack->out
              << '\n';
  });

  auto info = std::make_shared<InfoArgs>();
  auto* i = rig->add_subcommand("info",
                                "Print vertices, triangles, components, materials, shapes, the "
                                "meshes with morph targets and the channels the avatar can show");
  i->add_option("rig", info->rig, "Rig (GLB, .gltf, VRM or OBJ)")
      ->required()
      ->check(CLI::ExistingFile);
  i->add_flag("--json", info->json, "Print JSON");
  i->callback([info] { print_info(load_for_info(info->rig), info->json); });

  add_rig_build_commands(*rig);
}

}  // namespace facecast::cli
