#pragma once
// Subcommands of the `facecast` executable, one file per area. Each add_* registers its
// subcommands on the app; callbacks throw facecast::Error, which main() prints as one line.
#include <CLI/CLI.hpp>

namespace facecast::cli {

void add_rig_commands(CLI::App& app);
void add_viseme_commands(CLI::App& app);
void add_avatar_commands(CLI::App& app);
void add_render_commands(CLI::App& app);
void add_animate_commands(CLI::App& app);
void add_serve_commands(CLI::App& app);
void add_keys_commands(CLI::App& app);
/// `rig build` and `rig check`, added to the `rig` subcommand by add_rig_commands.
void add_rig_build_commands(CLI::App& rig);
/// `avatar from-photo`, added to the `avatar` subcommand by add_avatar_commands.
void add_avatar_photo_command(CLI::App& avatar);

}  // namespace facecast::cli
