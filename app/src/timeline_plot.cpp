// The timeline picture: lanes of viseme events and curves, expressions, two rig weights.
#include "facecast/app/timeline_plot.hpp"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>

#include <algorithm>
#include <cmath>

#include "facecast/core/error.hpp"

namespace facecast::cli {
namespace {

namespace OIIO = OIIO_NAMESPACE;

constexpr int kLane = 26, kLabel = 90, kTop = 22;

// A colour per lane index, spread around the hue circle.
std::array<float, 3> hue(int i) {
  const float h = std::fmod(i * 0.618034f, 1.0f) * 6.0f;
  const float x = 1.0f - std::abs(std::fmod(h, 2.0f) - 1.0f);
  const int k = static_cast<int>(h);
  std::array<float, 3> c{};
  c[(7 - k) % 3] = 1.0f;
  c[(k + 1 + (k % 2)) % 3] = x;
  for (float& v : c) v = 0.35f + 0.6f * v;
  return c;
}

struct Canvas {
  OIIO::ImageBuf buf;
  Canvas(int w, int h) : buf(OIIO::ImageSpec(w, h, 3, OIIO::TypeDesc::FLOAT)) {
    const float bg[3] = {0.12f, 0.13f, 0.15f};
    OIIO::ImageBufAlgo::fill(buf, bg);
  }
  void rect(int x0, int y0, int x1, int y1, const std::array<float, 3>& c) {
    OIIO::ImageBufAlgo::fill(buf, c, OIIO::ROI(x0, std::max(x1, x0 + 1), y0, std::max(y1, y0 + 1)));
  }
  void text(int x, int y, const std::string& s, int size = 13) {
    // Labels are a help, not a requirement: without a usable font the picture keeps its colours.
    const float white[3] = {0.9f, 0.9f, 0.9f};
    (void)OIIO::ImageBufAlgo::render_text(buf, x, y, s, size, "DejaVuSans", white);
    (void)buf.geterror();
  }
  // A curve with values in [0, 1] drawn in a lane whose bottom is at `base`.
  void curve(const std::vector<float>& v, int x0, int base, const std::array<float, 3>& c) {
    int prev = -1;
    for (size_t i = 0; i < v.size(); ++i) {
      const int y =
          base - static_cast<int>(std::lround(std::clamp(v[i], 0.0f, 1.0f) * (kLane - 4)));
      const int lo = prev < 0 ? y : std::min(prev, y), hi = prev < 0 ? y : std::max(prev, y);
      rect(x0 + static_cast<int>(i), lo, x0 + static_cast<int>(i) + 1, hi + 1, c);
      prev = y;
    }
  }
};

}  // namespace

render::Image plot_timeline(const viseme::Utterance& u, const anim::Performance& p, int pps) {
  const double seconds = p.duration();
  const int width = kLabel + std::max(400, static_cast<int>(std::ceil(seconds * pps)));
  const int samples = width - kLabel;
  const auto& names = p.shape_names();
  std::vector<std::string> exprs;
  for (const auto& e : u.expressions)
    if (std::find(exprs.begin(), exprs.end(), e.name) == exprs.end()) exprs.push_back(e.name);

  // Sample everything once.
  const size_t channels = p.viseme_channels(0).size();
  std::vector<std::vector<float>> ch(channels, std::vector<float>(samples));
  std::vector<std::vector<float>> ex(exprs.size(), std::vector<float>(samples));
  const auto find = [&](const char* a, const char* b) {
    for (const char* n : {a, b}) {
      const auto it = std::find(names.begin(), names.end(), n);
      if (it != names.end()) return static_cast<int>(it - names.begin());
    }
    return -1;
  };
  const int jaw = find("jawOpen", "jawOpen"), blink = find("eyeBlinkLeft", "eyeBlink_L");
  std::vector<float> jaw_v(samples), blink_v(samples), w(names.size());
  for (int x = 0; x < samples; ++x) {
    const double t = x * seconds / samples;
    const auto c = p.viseme_channels(t);
    for (size_t k = 0; k < channels; ++k) ch[k][x] = c[k];
    for (size_t k = 0; k < exprs.size(); ++k) ex[k][x] = p.expression_value(exprs[k], t);
    p.sample(t, w);
    if (jaw >= 0) jaw_v[x] = w[jaw];
    if (blink >= 0) blink_v[x] = w[blink];
  }

  // Lane 0: the events; then one lane per viseme channel (sil excluded), expressions, two weights.
  const int lanes = 1 + static_cast<int>(channels - 1 + exprs.size()) + 2;
  Canvas cv(width, kTop + lanes * kLane + 4);
  const auto sec_x = [&](double t) {
    return kLabel + static_cast<int>(std::lround(t * samples / seconds));
  };
  for (int s = 0; s <= static_cast<int>(seconds); ++s) {
    cv.rect(sec_x(s), kTop, sec_x(s) + 1, kTop + lanes * kLane, {0.25f, 0.25f, 0.28f});
    std::string label = std::to_string(s);
    label += " s";
    cv.text(sec_x(s) + 2, 14, label, 11);
  }
  const auto set_names = [&] {
    std::vector<std::string> n;
    for (const auto& v : u.visemes)
      if (std::find(n.begin(), n.end(), v.viseme) == n.end()) n.push_back(v.viseme);
    return n;
  }();
  int lane = 0;
  cv.text(4, kTop + kLane - 8, "visemes");
  for (const auto& v : u.visemes) {
    if (v.viseme == "sil" || v.viseme == "none") continue;
    const int idx = static_cast<int>(std::find(set_names.begin(), set_names.end(), v.viseme) -
                                     set_names.begin());
    cv.rect(sec_x(v.start) + 1, kTop + 3, sec_x(v.end), kTop + kLane - 3, hue(idx));
  }
  ++lane;
  const auto& channel_names = p.viseme_names();
  for (size_t k = 1; k < channels; ++k, ++lane) {
    const int base = kTop + (lane + 1) * kLane - 2;
    cv.rect(kLabel, base, width, base + 1, {0.2f, 0.2f, 0.22f});
    cv.text(4, base - 6, channel_names[k]);
    const auto it = std::find(set_names.begin(), set_names.end(), channel_names[k]);
    cv.curve(ch[k], kLabel, base, hue(static_cast<int>(it - set_names.begin())));
  }
  for (size_t k = 0; k < exprs.size(); ++k, ++lane) {
    const int base = kTop + (lane + 1) * kLane - 2;
    cv.text(4, base - 6, exprs[k]);
    cv.curve(ex[k], kLabel, base, {1.0f, 0.8f, 0.3f});
  }
  for (const auto& [label, values] : {std::pair{"jawOpen", &jaw_v}, std::pair{"blink", &blink_v}}) {
    const int base = kTop + (lane + 1) * kLane - 2;
    cv.text(4, base - 6, label);
    cv.curve(*values, kLabel, base, {0.6f, 0.9f, 1.0f});
    ++lane;
  }

  render::Image out;
  out.width = width;
  out.height = cv.buf.spec().height;
  out.channels = 3;
  out.pixels.resize(static_cast<size_t>(out.width) * out.height * 3);
  cv.buf.get_pixels(OIIO::ROI(0, out.width, 0, out.height, 0, 1, 0, 3), OIIO::TypeDesc::UINT8,
                    out.pixels.data());
  return out;
}

}  // namespace facecast::cli
