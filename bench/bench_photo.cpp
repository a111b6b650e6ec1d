// The photo avatar on scikit-image's astronaut.png (docs/algorithms.md#photo-avatar): the time of
// each stage of `facecast avatar from-photo` with the ICT FaceKit template (the template's loading
// apart). Usage: bench_photo [photo]
#include <chrono>
#include <iostream>

#include "facecast/render/image.hpp"
#include "facecast/rigbuild/photo_avatar.hpp"
#include "photo_support.hpp"

int main(int argc, char** argv) {
  using namespace facecast;
  const std::filesystem::path dir =
      std::filesystem::path(FACECAST_TEST_DATA_DIR) / "ict-facekit" / "FaceXModel";
  const std::filesystem::path photo = argc > 1 ? argv[1] : test::astronaut_path();
  if (photo.empty() || !std::filesystem::exists(dir)) {
    std::cerr << "bench_photo: needs astronaut.png (scripts/install-deps.sh) and " << dir << '\n';
    return 1;
  }
  auto t0 = std::chrono::steady_clock::now();
  const rigbuild::PhotoTemplate tmpl = rigbuild::load_photo_template(dir);
  const double load = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const rigbuild::PhotoOptions opt = rigbuild::load_photo_options();
  const render::Image image = render::read_image(photo);
  t0 = std::chrono::steady_clock::now();
  const rigbuild::PhotoAvatar a = rigbuild::avatar_from_photos(tmpl, image, nullptr, opt);
  const double build = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cout << "template load " << load << " s\n"
            << "astronaut build " << build << " s (limit 10 s): " << a.report["seconds"].dump()
            << '\n';
  return 0;
}
