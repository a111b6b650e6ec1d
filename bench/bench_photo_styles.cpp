// The photo avatar's accuracy as `facecast avatar from-photo` runs it (docs/algorithms.md#photo-
// avatar, docs/benchmarks.md#photo-avatar): the shipped template loaded as the command loads it,
// the options of configs/rigbuild/photo.json, on heads of known shape photographed in several
// styles (tests/rigbuild/photo_support.hpp: skin tone, baked light, background, lens, distance).
// Per style: the fitted/template shape error on identity mixtures and on warped heads (a warp no
// identity mode spans; beside it the nearest the modes reach, photo_support.hpp span_error), front
// photo alone and front + side; the template's own photo's error in cm; the side photo's fitted
// turn against the true one; the camera model the fit chose and its focal length against the true
// one. The expressions' transfer (the command's last stage) is left out: it runs after the fit
// and does not change it.
//
// Usage: bench_photo_styles [--seeds 3001,3002,...] [--count N] [--styles studio,window,selfie]
//        [--no-warp] [--no-own] [--camera auto|orthographic|perspective]
//        [--response STYLE,.. [--front-response]] [--scale F] [--blur PIXELS] [--jpeg QUALITY]
//        [--exif] [--coefficients] [--smile WEIGHT] [--mottle F]
// --styles: the benchmark's styles (all three by default) or the training styles pale, lamp, phone,
// deep (photo_support.hpp), which no option was chosen on either.
// --response: the detector's response measured on the template photographed in the named styles
// (the benchmark's, or photo_support.hpp's training styles pale, lamp, phone, deep), averaged over
// them and used by every fit (analysis by synthesis then skipped): the route of a table measured
// once and shipped with the template; --front-response: the front photo's only.
// --scale: every style's photos F times as many pixels across (the same lens: a larger face);
// --blur, --jpeg: the photos softened by a Gaussian and stored as JPEG, as a phone's camera does
// (the fit's renders are neither); --exif: the photos carry their lens's 35-mm equivalent focal
// length, whole millimetres, as phones and most cameras write it into EXIF.
// --coefficients: each head's identity coefficients, true and fitted (front + side, then front
// only; a warped head's true ones are its mixture's, the template's own photo's 0) with their
// posterior standard deviations, and per style and kind the mean error per mode (a bias
// the style's photos put on a mode: +1.1 on mode 7 by the window), the fitted coefficients'
// errors in those standard deviations (RMS z: about 1 when the fit's noise model holds, above 1
// when the detector's offsets it does not model pull the modes) and the mean standard deviation
// (with c ~ N(0, 1) as the heads are drawn, about the error ratio a fit whose noise model holds can
// reach).
// --mottle F: the skin's soft colour variation, a fraction of its colour (photo_support.hpp's
// default 0.06), in every style: how much the fit follows the skin's own shades.
// --smile W: the heads smile in the photos, teeth showing (mouthSmileLeft/Right at W, jawOpen at
// W / 4), and the error is measured against their neutral (the expressions the fit kept are
// noted per head).
// The default seeds are 3001.. (count 3): held out from every choice of the fit's options
// (tuning: 11-38; earlier held-out figures: 404-1313; development of this benchmark: 2001-2004).
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "build_paths.hpp"
#include "facecast/core/error.hpp"
#include "facecast/rigbuild/photo_avatar.hpp"
#include "photo_support.hpp"

namespace {

using namespace facecast;

struct Args {
  std::vector<unsigned> seeds;
  int count = 3;
  std::vector<std::string> styles;
  bool warp = true, own = true;
  std::string camera;                 // photo.json's camera model overridden ("": as configured)
  std::vector<std::string> response;  // styles the detector's response is measured in (averaged)
  bool front_response = false;        // ... the front's only
  double scale = 1;                   // the styles' photos this many times as many pixels across
  double mottle = -1;                 // the skin's soft variation (negative: the style's)
  double blur = 0;                    // the photos blurred (Gaussian, pixels)
  int jpeg = 0;                       // the photos stored as JPEG of this quality (0: not)
  bool exif = false;                  // the photos carry their lens's focal length (EXIF)
  bool coefficients = false;          // the mixtures' coefficients printed, true and fitted
  double smile = 0;                   // the heads smile in the photos (the truth stays neutral)
};

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::istringstream in(s);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw Error(arg + " needs a value");
      return argv[++i];
    };
    if (arg == "--seeds") {
      for (const auto& s : split(value())) a.seeds.push_back(static_cast<unsigned>(std::stoul(s)));
    } else if (arg == "--count") {
      a.count = std::stoi(value());
    } else if (arg == "--styles") {
      a.styles = split(value());
    } else if (arg == "--no-warp") {
      a.warp = false;
    } else if (arg == "--no-own") {
      a.own = false;
    } else if (arg == "--camera") {
      a.camera = value();
    } else if (arg == "--response") {
      a.response = split(value());
    } else if (arg == "--front-response") {
      a.front_response = true;
    } else if (arg == "--scale") {
      a.scale = std::stod(value());
    } else if (arg == "--mottle") {
      a.mottle = std::stod(value());
    } else if (arg == "--blur") {
      a.blur = std::stod(value());
    } else if (arg == "--jpeg") {
      a.jpeg = std::stoi(value());
    } else if (arg == "--exif") {
      a.exif = true;
    } else if (arg == "--coefficients") {
      a.coefficients = true;
    } else if (arg == "--smile") {
      a.smile = std::stod(value());
    } else {
      throw Error(
          "usage: bench_photo_styles [--seeds A,B,..] [--count N] [--styles a,b,..] "
          "[--no-warp] [--no-own] [--camera auto|orthographic|perspective] "
          "[--response a,b,.. [--front-response]] [--scale F] [--blur PIXELS] [--jpeg QUALITY] "
          "[--exif] [--coefficients] [--smile WEIGHT] [--mottle F]");
    }
  }
  if (a.seeds.empty())
    for (int k = 0; k < a.count; ++k) a.seeds.push_back(3001u + static_cast<unsigned>(k));
  return a;
}

// One fit's outcome.
struct Fit {
  bool ok = false;
  double error = 0;  // against the truth, model units
  double turn = 0;   // the side photo's fitted turn, degrees
  double focal = 0;  // the front camera's focal length, pixels (0: scale-orthographic)
  Eigen::VectorXd coefficients, sd;  // the identity coefficients and their posterior deviations
  std::string note;
};

Fit run_fit(const rigbuild::PhotoTemplate& tmpl, const test::PhotoShoot& shoot, bool with_side,
            const rig::Positions& truth, const rigbuild::PhotoOptions& opt) {
  Fit f;
  try {
    const rigbuild::PhotoAvatar a =
        rigbuild::avatar_from_photos(tmpl, shoot.front, with_side ? &shoot.side : nullptr, opt);
    f.ok = true;
    f.error = test::face_error(tmpl, a.fit.positions, truth);
    f.turn = test::fitted_turn_degrees(a.fit);
    f.focal = a.fit.front.focal();
    f.coefficients = a.fit.coefficients;
    f.sd = a.fit.coefficient_sd;
    for (const auto& n : a.report["notes"]) f.note += n.get<std::string>() + "; ";
    if (const std::string c = a.report["calibration_texture"]; !c.empty()) f.note += c;
    // The photos' pixels (appearance_evidence) and the two photos against each other
    // (stereo_evidence): used or left out, and the photo's move in scale.
    for (const auto& [key, label] : {std::pair{"appearance", "pixels front"},
                                     {"appearance_side", "pixels side"},
                                     {"stereo", "stereo"}})
      if (a.report.contains(key)) {
        const nlohmann::json& r = a.report[key];
        char buffer[64];
        std::snprintf(buffer, sizeof buffer, " %s %s (scale %+.1f %%)", label,
                      r.value("used", false) ? "used" : "out", 100 * r["move"][2].get<double>());
        f.note += buffer;
      }
    for (const auto& [name, w] : a.report["expression"].items())
      f.note += " " + name + " " + std::to_string(w.get<double>()).substr(0, 4);
  } catch (const Error& e) {
    f.note = e.what();
  }
  return f;
}

struct Summary {
  std::vector<double> front, both;  // fitted/template ratios
  int side_lower = 0, failed = 0;
  std::vector<double> turn_error;  // fitted - true, degrees
  std::vector<double> focal;       // fitted focal lengths (0: orthographic), front + side fits
  std::vector<double> z;           // front + side mixtures: (fitted - true) / posterior sd
  std::vector<double> sd;          // ... and those posterior sds
  Eigen::VectorXd bias;            // ... the mean of fitted - true per mode
  std::vector<double> span;        // warped heads: the modes' nearest / template (span_error)

  void add(const Fit& a, const Fit& b, double before, double true_turn) {
    if (!a.ok || !b.ok) {
      ++failed;
      return;
    }
    front.push_back(a.error / before);
    both.push_back(b.error / before);
    side_lower += b.error < a.error ? 1 : 0;
    turn_error.push_back(b.turn - true_turn);
    focal.push_back(b.focal);
  }
};

double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0.0 : s / static_cast<double>(v.size());
}
double max_of(const std::vector<double>& v) {
  return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
}
double max_abs(const std::vector<double>& v) {
  double m = 0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

std::string list(const std::vector<double>& v, int precision = 2) {
  std::ostringstream o;
  o.precision(precision);
  o << std::fixed;
  for (std::size_t i = 0; i < v.size(); ++i) o << (i ? " " : "") << v[i];
  return o.str();
}

}  // namespace

int main(int argc, char** argv) try {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // each line as it comes (runs take minutes)
  const Args args = parse(argc, argv);
  // As the command: its options and its template (photo.json's, else the shipped one).
  rigbuild::PhotoOptions opt = rigbuild::load_photo_options();
  opt.shapes = false;  // the expressions' transfer follows the fit and does not change it
  if (!args.camera.empty()) opt.camera = args.camera;
  rigbuild::PhotoTemplate tmpl =
      rigbuild::load_photo_template(rigbuild::photo_template_path(opt, ""));
  const auto dir = test::build_dir() / "test-artifacts" / "photo";
  std::filesystem::create_directories(dir);
  const auto styles = test::photo_styles(dir / "room_background.png");
  std::cout << "template " << rigbuild::photo_template_path(opt, "").filename().string() << " ("
            << tmpl.rig.vertex_count() << " vertices, " << tmpl.modes.size()
            << " identity modes); seeds "
            << list(std::vector<double>(args.seeds.begin(), args.seeds.end()), 0) << "\n";
  const auto t0 = std::chrono::steady_clock::now();
  if (!args.response.empty()) {
    // The fixed-table route: the response measured on the template in each named style (its
    // photos' perspective measured against a perspective camera), the mean used for every fit.
    rigbuild::PhotoTemplate sum = tmpl;
    sum.mode_bias.assign(tmpl.modes.size(), rigbuild::zero_landmark_vectors());
    sum.side_mode_bias = sum.mode_bias;
    int n = 0;
    auto all = styles;
    for (const auto& t : test::training_photo_styles(dir / "room_background.png")) all.push_back(t);
    for (const auto& [style, yaw] : all) {
      if (std::find(args.response.begin(), args.response.end(), style.name) == args.response.end())
        continue;
      rigbuild::PhotoOptions o = opt;
      if (style.distance > 0) o.camera = "perspective";
      rigbuild::PhotoTemplate t = tmpl;
      const render::Image tex = test::skin_texture(tmpl, 512, style);
      rigbuild::measure_detector_response(
          t,
          [&](const rig::Positions& p) {
            const test::PhotoShoot s = test::photograph(tmpl, p, yaw, style, tex);
            return std::make_pair(s.front, args.front_response ? render::Image{} : s.side);
          },
          o);
      for (std::size_t k = 0; k < rigbuild::kLandmarkCount; ++k) {
        sum.bias[k] += t.bias[k];
        sum.side_bias[k] += t.side_bias[k];
        for (std::size_t m = 0; m < tmpl.modes.size(); ++m) {
          sum.mode_bias[m][k] += t.mode_bias[m][k];
          sum.side_mode_bias[m][k] += t.side_mode_bias[m][k];
        }
      }
      ++n;
    }
    if (n == 0) throw Error("--response: no such style");
    for (std::size_t k = 0; k < rigbuild::kLandmarkCount; ++k) {
      sum.bias[k] /= n;
      sum.side_bias[k] /= n;
      for (std::size_t m = 0; m < tmpl.modes.size(); ++m) {
        sum.mode_bias[m][k] /= n;
        sum.side_mode_bias[m][k] /= n;
      }
    }
    tmpl = std::move(sum);
    std::printf("detector response measured in %d styles (%.0f s)\n", n,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  // --styles may also name the training styles, which no option was chosen on.
  auto named_styles = styles;
  if (!args.styles.empty())
    for (const auto& t : test::training_photo_styles(dir / "room_background.png"))
      named_styles.push_back(t);
  for (const auto& [named, turn] : named_styles) {
    if (!args.styles.empty() &&
        std::find(args.styles.begin(), args.styles.end(), named.name) == args.styles.end())
      continue;
    test::PhotoStyle style = named;
    const double yaw = turn;
    style.width = static_cast<int>(std::lround(style.width * args.scale));
    style.height = static_cast<int>(std::lround(style.height * args.scale));
    if (args.mottle >= 0) style.mottle = args.mottle;
    const auto ts = std::chrono::steady_clock::now();
    const render::Image texture = test::skin_texture(tmpl, 512, style);
    // Photographed as the style's camera stores it (--blur, --jpeg, --exif).
    const double focal_35mm = args.exif ? std::round(test::focal_35mm(style)) : 0.0;
    // --smile: the head smiles, its teeth showing (mouthSmileLeft/Right at the weight, jawOpen at
    // a quarter of it).
    rigbuild::PhotoOptions smile_shapes;
    smile_shapes.expressions = {"jawOpen", "mouthSmileLeft", "mouthSmileRight"};
    const rigbuild::PhotoTemplate smiling = rigbuild::with_photo_expressions(tmpl, smile_shapes);
    const auto photograph = [&](const rig::Positions& neutral) {
      rig::Positions p = neutral;
      for (std::size_t e = 0; e < smiling.expressions.size() && args.smile > 0; ++e)
        p += static_cast<float>(smiling.expression_names[e] == "jawOpen" ? args.smile / 4
                                                                         : args.smile) *
             smiling.expressions[e];
      test::PhotoShoot s = test::photograph(tmpl, p, yaw, style, texture);
      s.front = test::as_camera_stores(std::move(s.front), args.blur, args.jpeg);
      s.side = test::as_camera_stores(std::move(s.side), args.blur, args.jpeg);
      s.front.focal_35mm = s.side.focal_35mm = focal_35mm;
      return s;
    };
    std::cout << "\nstyle " << style.name << ": " << style.width << "x" << style.height << ", "
              << style.fov_y_deg << "-degree lens (focal " << std::lround(test::focal_pixels(style))
              << " px)"
              << (style.distance > 0 ? ", camera " + std::to_string(std::lround(style.distance)) +
                                           " cm from the face"
                                     : std::string(", framed"))
              << ", side turned " << yaw << " degrees\n";
    const auto heads = [&](const char* kind, bool warped) {
      Summary s;
      for (unsigned seed : args.seeds) {
        const rig::Positions truth =
            warped ? test::warped_head(tmpl, seed) : test::identity_mixture(tmpl, seed);
        const test::PhotoShoot shoot = photograph(truth);
        if (seed == args.seeds.front())
          render::write_image(dir / ("style_" + style.name + "_" + kind + ".png"),
                              rigbuild::side_by_side({shoot.front, shoot.side}));
        const double before = test::face_error(tmpl, tmpl.rig.positions, truth);
        const Fit a = run_fit(tmpl, shoot, false, truth, opt);
        const Fit b = run_fit(tmpl, shoot, true, truth, opt);
        const std::string notes = a.note + (a.note.empty() || b.note.empty() ? "" : ", ") + b.note;
        std::printf(
            "  %s %u: template %.3f cm; fitted/template front %.3f, front+side %.3f; turn "
            "%.1f; focal %.0f%s%s\n",
            kind, seed, before, a.ok ? a.error / before : -1.0, b.ok ? b.error / before : -1.0,
            b.turn, b.focal, notes.empty() ? "" : "; ", notes.c_str());
        s.add(a, b, before, yaw);
        if (warped) {
          s.span.push_back(test::span_error(tmpl, truth) / before);
          std::printf("    the modes' nearest / template %.2f\n", s.span.back());
        }
        if (args.coefficients && b.ok) {
          const Eigen::VectorXd c = test::identity_coefficients(tmpl, seed);
          std::printf("    coefficients, true / fitted (sd):");
          for (Eigen::Index k = 0; k < c.size(); ++k) {
            std::printf(" %+.2f / %+.2f (%.2f)", c(k), b.coefficients(k), b.sd(k));
            s.z.push_back((b.coefficients(k) - c(k)) / b.sd(k));
            if (s.bias.size() != c.size()) s.bias = Eigen::VectorXd::Zero(c.size());
            s.bias(k) += (b.coefficients(k) - c(k)) / static_cast<double>(args.seeds.size());
            s.sd.push_back(b.sd(k));
          }
          std::printf("\n");
          if (a.ok) {
            std::printf("    front only, true / fitted (sd):");
            for (Eigen::Index k = 0; k < c.size(); ++k)
              std::printf(" %+.2f / %+.2f (%.2f)", c(k), a.coefficients(k), a.sd(k));
            std::printf("\n");
          }
        }
      }
      std::printf(
          "  %s: fitted/template front %.2f (max %.2f), front+side %.2f (max %.2f); the "
          "side photo lowers it on %d of %zu; turn error mean %+.1f, max |%.1f| degrees; "
          "%d failed\n",
          kind, mean(s.front), max_of(s.front), mean(s.both), max_of(s.both), s.side_lower,
          s.both.size(), mean(s.turn_error), max_abs(s.turn_error), s.failed);
      if (!s.span.empty())
        std::printf("  %s: the modes' nearest / template %.2f (max %.2f)\n", kind, mean(s.span),
                    max_of(s.span));
      if (!s.z.empty()) {
        double zz = 0;
        for (double z : s.z) zz += z * z;
        std::printf(
            "  %s coefficients (front + side): RMS error / sd %.2f over %zu; mean sd %.2f\n", kind,
            std::sqrt(zz / static_cast<double>(s.z.size())), s.z.size(), mean(s.sd));
        std::printf("  %s coefficients' mean error per mode (a style's bias):", kind);
        for (Eigen::Index k = 0; k < s.bias.size(); ++k) std::printf(" %+.2f", s.bias(k));
        std::printf("\n");
      }
      return s;
    };
    heads("mixture", false);
    if (args.warp) heads("warped", true);
    if (args.own) {
      // Three shots, the head moved by half a pixel between them: the median (one shot's figure
      // moves by up to a tenth of a centimetre).
      std::array<double, 3> front{}, both{};
      const auto shifts = test::own_photo_shifts();
      for (std::size_t i = 0; i < shifts.size(); ++i) {
        const rig::Positions at = tmpl.rig.positions.rowwise() + shifts[i];
        const test::PhotoShoot shoot = photograph(at);
        const Fit a = run_fit(tmpl, shoot, false, at, opt);
        const Fit b = run_fit(tmpl, shoot, true, at, opt);
        front[i] = a.ok ? a.error : -1.0;
        both[i] = b.ok ? b.error : -1.0;
        const std::string notes = a.note + (a.note.empty() || b.note.empty() ? "" : ", ") + b.note;
        std::printf(
            "  own photo, shot %zu: error front %.3f cm, front+side %.3f cm; turn %.1f (true "
            "%.0f); focal %.0f%s%s\n",
            i + 1, front[i], both[i], b.turn, yaw, b.focal, notes.empty() ? "" : "; ",
            notes.c_str());
        if (args.coefficients && b.ok) {
          std::printf("    coefficients, true / fitted (sd):");
          for (Eigen::Index k = 0; k < b.coefficients.size(); ++k)
            std::printf(" +0.00 / %+.2f (%.2f)", b.coefficients(k), b.sd(k));
          std::printf("\n");
        }
      }
      std::printf("  own photo: error front %.3f cm, front+side %.3f cm (the median of 3 shots)\n",
                  test::median_of_three(front), test::median_of_three(both));
    }
    std::printf("  (%.0f s)\n",
                std::chrono::duration<double>(std::chrono::steady_clock::now() - ts).count());
  }
  std::printf("\n%.0f s in all\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  return 0;
} catch (const std::exception& e) {
  std::cerr << "bench_photo_styles: " << e.what() << '\n';
  return 1;
}
