#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/rig/rig_io.hpp"
#include "test_data.hpp"

using namespace facecast;
using namespace facecast::rig;

namespace {

// A unit cube of quads in two groups and two materials, with UVs: 8 vertices, 12 triangles.
constexpr const char* kCube = R"(# cube
v -1 -1 1
v 1 -1 1
v 1 1 1
v -1 1 1
v -1 -1 -1
v 1 -1 -1
v 1 1 -1
v -1 1 -1
vt 0 0
vt 1 0
vt 1 1
vt 0 1
g front
usemtl red
f 1/1 2/2 3/3 4/4
f 2/1 6/2 7/3 3/4
g back
usemtl blue
f 6/1 5/2 8/3 7/4
f 5/1 1/2 4/3 8/4
f 4/1 3/2 7/3 8/4
f -4/1 -3/2 -7/3 -8/4
)";

Rig cube_with_shapes() {
  Rig r = parse_obj(kCube, "cube.obj");
  Positions up = Positions::Zero(8, 3);
  up.row(2) << 0, 0.5f, 0;
  up.row(3) << 0, 0.5f, 0;
  r.shapes.push_back(Blendshape::from_dense("topUp", up));
  Positions side = Positions::Zero(8, 3);
  side.row(1) << 0.25f, 0, 0.125f;
  r.shapes.push_back(Blendshape::from_dense("sidePush", side));
  r.landmarks.push_back({"corner", 6});
  return r;
}

std::vector<Eigen::RowVector3f> raw_v_lines(const std::filesystem::path& p) {
  // An independent reader: sscanf on every "v " line, in file order.
  std::ifstream in(p);
  std::vector<Eigen::RowVector3f> out;
  std::string line;
  while (std::getline(in, line)) {
    float x, y, z;
    if (line.rfind("v ", 0) == 0 && std::sscanf(line.c_str() + 2, "%f %f %f", &x, &y, &z) == 3) {
      out.emplace_back(x, y, z);
    }
  }
  return out;
}

std::string error_of(auto&& fn) {
  try {
    fn();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("OBJ parse keeps order, triangulates, keeps groups, materials and UVs", "[rig][obj]") {
  const Rig r = parse_obj(kCube, "cube.obj");
  CHECK(r.vertex_count() == 8);
  CHECK(r.triangle_count() == 12);
  CHECK(r.positions.row(6) == Eigen::RowVector3f(1, 1, -1));
  REQUIRE(r.materials.size() == 2);
  CHECK(r.materials[0].name == "red");
  CHECK(r.triangle_material[0] == 0);
  CHECK(r.triangle_material[11] == 1);
  REQUIRE(r.groups.size() == 2);
  CHECK(r.triangle_group[4] == 1);
  CHECK(r.uvs.rows() == 8);
  // Negative indices: the last face is 5 6 2 1 (1-based) -> fan (4,5,1) and (4,1,0).
  CHECK(r.triangles.row(10) == Eigen::RowVector3i(4, 5, 1));
  CHECK(r.triangles.row(11) == Eigen::RowVector3i(4, 1, 0));
  CHECK(connected_components(r.vertex_count(), r.triangles).count == 1);
  // Outward normals on a closed cube.
  CHECK(r.normals.row(6).dot(Eigen::RowVector3f(1, 1, -1).normalized()) > 0.95f);
}

TEST_CASE("OBJ -> Rig -> GLB -> Rig round-trips within 1e-5", "[rig][glb]") {
  const Rig a = cube_with_shapes();
  const Rig b = parse_glb(glb_bytes(a), "cube.glb");
  REQUIRE(b.vertex_count() == a.vertex_count());
  CHECK((b.positions - a.positions).cwiseAbs().maxCoeff() < 1e-5f);
  CHECK((b.uvs - a.uvs).cwiseAbs().maxCoeff() < 1e-5f);
  CHECK((b.normals - a.normals).cwiseAbs().maxCoeff() < 1e-5f);
  REQUIRE(b.shapes.size() == 2);
  CHECK(b.shapes[0].name == "topUp");
  CHECK(b.shapes[1].name == "sidePush");
  for (std::size_t s = 0; s < 2; ++s) {
    CHECK((b.shapes[s].dense(8) - a.shapes[s].dense(8)).cwiseAbs().maxCoeff() < 1e-5f);
  }
  CHECK(b.shapes[0].vertices == std::vector<int>{2, 3});
  REQUIRE(b.materials.size() == 2);
  CHECK(b.materials[1].name == "blue");
  CHECK(b.triangle_count() == 12);
  REQUIRE(b.landmarks.size() == 1);
  CHECK(b.landmarks[0].vertex == 6);
  // Same triangles per material (GLB groups them by material).
  for (int m = 0; m < 2; ++m) {
    int na = 0, nb = 0;
    for (int f = 0; f < 12; ++f) {
      na += a.triangle_material[f] == m;
      nb += b.triangle_material[f] == m;
    }
    CHECK(na == nb);
  }
}

TEST_CASE("OBJ write and read back", "[rig][obj]") {
  const Rig a = cube_with_shapes();
  const auto dir = test::scratch_dir() / "objfolder";
  write_obj_folder(dir, a);
  const Rig b = read_obj_shapes(dir / "neutral.obj", dir);
  CHECK((b.positions - a.positions).cwiseAbs().maxCoeff() == 0.0f);
  REQUIRE(b.shapes.size() == 2);
  CHECK(b.shapes[0].name == "sidePush");  // name order
  CHECK((b.shapes[1].dense(8) - a.shapes[0].dense(8)).cwiseAbs().maxCoeff() < 1e-6f);
  CHECK(b.materials.size() == 2);
  CHECK(b.groups.size() == 2);
}

TEST_CASE("bad OBJ input gives a clear error", "[rig][obj][errors]") {
  CHECK(error_of([] { read_obj("/nonexistent/face.obj"); }) ==
        "/nonexistent/face.obj: cannot open file");
  CHECK(error_of([] { parse_obj("v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n", "a.obj"); }) ==
        "a.obj:2: non-finite coordinate 'nan'");
  CHECK(error_of([] { parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "b.obj"); }) ==
        "b.obj:4: face index 4 out of range (3 vertices)");
  CHECK(error_of([] { parse_obj("v 0 0 0\nv 1 0\n", "c.obj"); }) ==
        "c.obj:2: expected 3 numbers in 'v' record");
  CHECK(error_of([] { parse_obj("# nothing\n", "d.obj"); }) == "d.obj: mesh has no vertices");
  CHECK(error_of([] { parse_obj("v 0 0 0\n", "e.obj"); }) == "e.obj: mesh has no faces");
  CHECK(error_of([] { parse_obj("v 0 0 0\nv 1 0 0\nf 1 2\n", "f.obj"); }) ==
        "f.obj:3: face with fewer than 3 vertices");
  CHECK(error_of([] { parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 x\n", "g.obj"); }) ==
        "g.obj:3: bad number 'x'");
}

TEST_CASE("a shape with another vertex count is an error naming the file", "[rig][obj][errors]") {
  const auto dir = test::scratch_dir() / "mismatch";
  write_obj_folder(dir, cube_with_shapes());
  write_file_atomic(dir / "extra.obj", std::string("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"));
  const std::string msg = error_of([&] { read_obj_shapes(dir / "neutral.obj", dir); });
  CHECK(msg == (dir / "extra.obj").string() + ": 3 vertices, but the neutral has 8");
  // Excluded by pattern, it is fine.
  CHECK(read_obj_shapes(dir / "neutral.obj", dir, {"ext*"}).shapes.size() == 2);
}

TEST_CASE("bad GLB input gives a clear error and failed writes leave no file",
          "[rig][glb][errors]") {
  CHECK_THROWS_AS(parse_glb("glTF but not really", "x.glb"), Error);
  CHECK(error_of([] { read_glb("/nonexistent/x.glb"); }) == "/nonexistent/x.glb: cannot open file");
  std::string bytes = glb_bytes(cube_with_shapes());
  CHECK_THROWS_AS(parse_glb(std::string_view(bytes).substr(0, bytes.size() / 2), "cut.glb"), Error);

  Rig nan_rig = cube_with_shapes();
  nan_rig.positions(3, 1) = std::nanf("");
  const auto out = test::scratch_dir() / "nan.glb";
  CHECK(error_of([&] { write_glb(out, nan_rig); }) == "rig: non-finite vertex coordinate");
  CHECK_FALSE(std::filesystem::exists(out));
  Rig empty;
  CHECK(error_of([&] { write_glb(out, empty); }) == "rig: mesh has no vertices");
}

TEST_CASE("ICT FaceKit: vertex order kept for the neutral and every expression", "[rig][ict]") {
  const auto dir = test::ict_dir();
  if (!test::require_data(dir / "generic_neutral_mesh.obj")) return;
  const Rig rig = read_obj_shapes(dir / "generic_neutral_mesh.obj", dir, {"identity*"});
  REQUIRE(rig.vertex_count() == 26719);
  REQUIRE(rig.shapes.size() == 57);
  CHECK(rig.materials.size() == 12);
  CHECK(connected_components(rig.vertex_count(), rig.triangles).count > 10);

  const Rig back = parse_glb(glb_bytes(rig), "ict.glb");
  const auto neutral = raw_v_lines(dir / "generic_neutral_mesh.obj");
  REQUIRE(neutral.size() == 26719);
  float worst = 0;
  for (int v = 0; v < 26719; ++v)
    worst = std::max(worst, (back.positions.row(v) - neutral[v]).norm());
  CHECK(worst < 1e-5f);
  for (const auto& s : back.shapes) {
    const auto truth = raw_v_lines(dir / (s.name + ".obj"));
    REQUIRE(truth.size() == 26719);
    const Positions d = s.dense(26719);
    float err = 0;
    for (int v = 0; v < 26719; ++v) {
      err = std::max(err, (back.positions.row(v) + d.row(v) - truth[v]).norm());
    }
    INFO(s.name);
    CHECK(err < 1e-5f);
  }
}

TEST_CASE("OBJ materials: Kd, d/Tr as blending, map_Kd textures, looks by name", "[rig][obj]") {
  const auto dir = test::scratch_dir() / "mtl";
  std::filesystem::create_directories(dir);
  std::string obj = std::string("mtllib cube.mtl\n") + kCube;
  obj.replace(obj.find("usemtl blue"), 11, "usemtl M_EyeBlend");
  write_file_atomic(dir / "cube.obj", obj);
  const std::string png("\x89PNG\r\n\x1a\n fake but signed", 24);
  write_file_atomic(dir / "skin.png", png);
  write_file_atomic(dir / "cube.mtl",
                    "newmtl red\nKd 1 0 0\nd 0.5\nmap_Kd -bm 1 skin.png\n"
                    "newmtl M_EyeBlend\nKd 0.5 0.5 0.5\n");
  const Rig r = read_obj(dir / "cube.obj");
  REQUIRE(r.materials.size() == 2);
  const Material& red = r.materials[0];
  CHECK(red.base_color.isApprox(Eigen::Vector4f(1, 0, 0, 0.5f)));
  CHECK(red.alpha_mode == AlphaMode::kBlend);
  REQUIRE(red.base_color_texture.texture == 0);
  CHECK(r.textures[0].name == "skin.png");
  CHECK(r.textures[0].mime_type == "image/png");
  CHECK(r.textures[0].bytes == png);
  // configs/rig/materials.json: the ICT FaceKit's eye-blend shell is a transparent overlay.
  CHECK(r.materials[1].alpha_mode == AlphaMode::kBlend);
  CHECK(r.materials[1].base_color[3] == 0.0f);

  // A texture that is missing or not PNG/JPEG only loses the texture; Tr is 1 - d.
  write_file_atomic(dir / "cube.mtl", "newmtl red\nTr 0.25\nmap_Kd missing.png\n");
  const Rig r2 = read_obj(dir / "cube.obj");
  CHECK(r2.materials[0].base_color[3] == Approx(0.75f));
  CHECK(r2.materials[0].base_color_texture.texture == -1);
  CHECK(r2.textures.empty());
}
