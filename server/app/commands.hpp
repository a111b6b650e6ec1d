#pragma once
// Subcommands of the `facecast` executable, one file per area. Each add_* registers its
// subcommands on the app; callbacks throw facecast::Error, which main() prints as one line.
#include <CLI/CLI.hpp>

namespace facecast::cli {

void add_rig_commands(CLI::App& app);

}  // namespace facecast::cli
