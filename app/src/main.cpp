// facecast — one executable, many subcommands. See `facecast --help`.
#include <iostream>

#include "facecast/app/commands.hpp"
#include "facecast/core/error.hpp"

int main(int argc, char** argv) {
  CLI::App app{"Facecast: speech-driven avatar animation server", "facecast"};
  app.set_version_flag("--version", std::string("facecast ") + FACECAST_VERSION);
  app.require_subcommand(1);
  app.fallthrough(false);
  facecast::cli::add_rig_commands(app);
  facecast::cli::add_viseme_commands(app);
  facecast::cli::add_avatar_commands(app);
  facecast::cli::add_render_commands(app);
  facecast::cli::add_animate_commands(app);
  facecast::cli::add_serve_commands(app);
  facecast::cli::add_keys_commands(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const facecast::Error& e) {
    std::cerr << "facecast: " << e.what() << '\n';
    return e.code() == facecast::ErrorCode::kInternal ? 3 : 2;
  } catch (const std::exception& e) {
    std::cerr << "facecast: internal error: " << e.what() << '\n';
    return 3;
  }
  return 0;
}
