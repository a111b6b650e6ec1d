// The photo avatar on scikit-image's astronaut.png (docs/algorithms.md#photo-avatar): the time of
// each stage of `facecast avatar from-photo` (the template's loading apart) with the shipped
// template (what the command uses: the ICT FaceKit packed, 74 shapes), then with the ICT FaceKit's
// own folder (what the tests use: its 53 expressions at full resolution). Usage: bench_photo
// [photo]
#include <sys/resource.h>

#include <chrono>
#include <iostream>
#include <string>
#include <vector>

#include "build_paths.hpp"
#include "facecast/render/image.hpp"
#include "facecast/rigbuild/photo_avatar.hpp"
#include "facecast/rigbuild/template.hpp"
#include "photo_support.hpp"

namespace {

// CPU seconds of this process so far (all threads, user + system): the figure to compare on a
// shared machine, where the wall-clock stage times depend on the load.
double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

using namespace facecast;

void run(const std::string& name, const rigbuild::PhotoTemplate& tmpl, const render::Image& image,
         const rigbuild::PhotoOptions& opt) {
  // CPU time per top-level stage, from the progress reports (stage names as in the report).
  std::vector<std::pair<std::string, double>> marks;
  const double cpu0 = cpu_seconds();
  const ProgressFn progress = [&](std::string_view stage, double) {
    if (marks.empty() || marks.back().first != stage) marks.emplace_back(stage, cpu_seconds());
  };
  const auto t0 = std::chrono::steady_clock::now();
  const rigbuild::PhotoAvatar a = rigbuild::avatar_from_photos(tmpl, image, nullptr, opt, progress);
  const double build = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu = cpu_seconds() - cpu0;
  std::cout << name << " (" << tmpl.rig.shapes.size() << " shapes): astronaut build " << build
            << " s wall (limit 10 s): " << a.report["seconds"].dump() << "\n  CPU " << cpu << " s:";
  for (std::size_t i = 0; i + 1 < marks.size(); ++i)
    std::cout << ' ' << marks[i].first << ' ' << marks[i + 1].second - marks[i].second;
  std::cout << '\n';
}

}  // namespace

int main(int argc, char** argv) {
  const std::filesystem::path dir = facecast::test::test_data_dir() / "ict-facekit" / "FaceXModel";
  const std::filesystem::path photo = argc > 1 ? argv[1] : test::astronaut_path();
  if (photo.empty() || !std::filesystem::exists(dir)) {
    std::cerr << "bench_photo: needs astronaut.png (scripts/install-deps.sh) and " << dir << '\n';
    return 1;
  }
  const rigbuild::PhotoOptions opt = rigbuild::load_photo_options();
  const render::Image image = render::read_photo(photo);
  for (const auto& [name, path] : {std::pair<std::string, std::filesystem::path>{
                                       "shipped template", rigbuild::shipped_template_path()},
                                   {"ICT FaceKit folder", dir}})
    run(name, rigbuild::load_photo_template(path), image, opt);
  return 0;
}
