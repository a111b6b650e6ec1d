// The timeline picture of `facecast animate --plot`.
#include <catch2/catch.hpp>

#include "facecast/anim/animation.hpp"
#include "facecast/app/timeline_plot.hpp"
#include "facecast/avatar/avatar.hpp"

using namespace facecast;

TEST_CASE("the timeline picture draws events and curves", "[app][timeline]") {
  const rig::Rig rig = avatar::default_avatar();
  viseme::Utterance u;
  u.set = viseme::VisemeSet::kOculus;
  u.visemes = {{"sil", 0, 0.2}, {"aa", 0.2, 0.5}, {"PP", 0.5, 0.6}, {"sil", 0.6, 1.0}};
  u.expressions = {{"joy", 63, 0.1, 0.3}};
  u.duration = 1.0;
  const anim::Performance p(u, anim::Mapping::for_rig(rig.shape_names()));
  const render::Image im = cli::plot_timeline(u, p, 400);
  CHECK(im.width >= 400 + 90);
  // 1 event lane + 14 channels + 1 expression + jaw + blink, 26 px each, under a 22 px header.
  CHECK(im.height == 22 + 18 * 26 + 4);
  // Something is drawn in the event lane inside the "aa" event, and nothing before it starts.
  const auto lit = [&](int x, int y0, int y1) {
    for (int y = y0; y < y1; ++y)
      if (im.at(x, y, 0) > 60 || im.at(x, y, 1) > 60 || im.at(x, y, 2) > 60) return true;
    return false;
  };
  const int x_aa = 90 + static_cast<int>(0.35 / p.duration() * (im.width - 90));
  const int x_rest = 90 + static_cast<int>(0.05 / p.duration() * (im.width - 90));
  CHECK(lit(x_aa, 25, 45));
  CHECK(!lit(x_rest, 25, 45));
}
