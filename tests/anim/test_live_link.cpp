// Live Link Face takes: the app's 63 columns, its timecode, shapes matched by name.
#include <catch2/catch.hpp>
#include <sstream>

#include "facecast/anim/live_link.hpp"

using namespace facecast::anim;

namespace {

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream in(line);
  for (std::string cell; std::getline(in, cell, ',');) out.push_back(cell);
  return out;
}

}  // namespace

TEST_CASE("Live Link Face timecodes count frames of the take's rate", "[anim][livelink]") {
  CHECK(live_link_timecode(0, 60) == "00:00:00:00.000");
  CHECK(live_link_timecode(59, 60) == "00:00:00:59.000");
  CHECK(live_link_timecode(61, 60) == "00:00:01:01.000");
  CHECK(live_link_timecode(30 * 3661 + 7, 30) == "01:01:01:07.000");
  // 29.97 fps: frame 30 is 1.001 s in, 0.03 of a frame past the first frame of second 1.
  CHECK(live_link_timecode(30, 29.97) == "00:00:01:00.030");
  CHECK(live_link_timecode(1, 29.97) == "00:00:00:01.000");
}

TEST_CASE("a Live Link Face take: 63 columns, the ARKit shapes by name, one row per frame",
          "[anim][livelink]") {
  WeightTrack t;
  t.shapes = {"jawOpen", "eyeBlink_L", "MouthLeft", "viseme_aa"};  // ARKit, ICT and other names
  t.fps = 30;
  t.frames = 3;
  t.weights = {0.5f, 0.1f, 0.2f, 0.9f, 0.0f, 0.0f, 0.0f, 0.0f, 1.0f, 1.0f, 1.0f, 1.0f};
  t.head = {{0.1f, -0.2f, 0.05f}, {}, {}};
  std::stringstream csv(to_live_link_csv(t));
  std::string line;
  std::getline(csv, line);
  const auto header = split(line);
  REQUIRE(header.size() == 63);
  CHECK(header[0] == "Timecode");
  CHECK(header[1] == "BlendShapeCount");
  CHECK(header[2] == "EyeBlinkLeft");
  CHECK(header[17] == "JawRight");  // the app's order: JawRight, JawLeft; MouthRight, MouthLeft
  CHECK(header[18] == "JawLeft");
  CHECK(header[19] == "JawOpen");
  CHECK(header[53] == "TongueOut");
  CHECK(header[54] == "HeadYaw");
  CHECK(header[62] == "RightEyeRoll");
  std::vector<std::vector<std::string>> rows;
  while (std::getline(csv, line)) rows.push_back(split(line));
  REQUIRE(rows.size() == 3);
  for (const auto& r : rows) {
    REQUIRE(r.size() == 63);
    CHECK(r[1] == "61");
  }
  CHECK(rows[0][0] == "00:00:00:00.000");
  CHECK(rows[2][0] == "00:00:00:02.000");
  CHECK(std::stod(rows[0][19]) == Approx(0.5));  // JawOpen
  CHECK(std::stod(rows[0][2]) == Approx(0.1));   // EyeBlinkLeft from eyeBlink_L
  CHECK(std::stod(rows[0][24]) == Approx(0.2));  // MouthLeft
  CHECK(std::stod(rows[0][23]) == 0.0);          // MouthRight: the track has none
  CHECK(std::stod(rows[0][54]) == Approx(0.1));  // HeadYaw
  CHECK(std::stod(rows[0][55]) == Approx(-0.2));
  CHECK(std::stod(rows[2][19]) == Approx(1.0));
}

TEST_CASE("the ARKit names of a take are its columns in camelCase", "[anim][livelink]") {
  const auto names = arkit_shape_names();
  REQUIRE(names.size() == 52);
  CHECK(names.front() == "eyeBlinkLeft");
  CHECK(names[17] == "jawOpen");
  CHECK(names.back() == "tongueOut");
}
