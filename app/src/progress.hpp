#pragma once
// Progress for long CLI work: a single redrawn line on a terminal, one line per stage otherwise.
#include <unistd.h>
#include <cstdio>
#include <string>

#include "facecast/core/progress.hpp"

namespace facecast::cli {

inline ProgressFn terminal_progress() {
  const bool tty = isatty(STDERR_FILENO);
  auto last = std::make_shared<std::string>();
  return [tty, last](std::string_view stage, double fraction) {
    const int pct = static_cast<int>(fraction * 100.0 + 0.5);
    if (tty) {
      const int bar = pct / 5;
      std::fprintf(stderr, "\r%-24.*s [%-20.*s] %3d%%", static_cast<int>(stage.size()),
                   stage.data(), bar, "####################", pct);
      if (stage == "done") std::fputc('\n', stderr);
    } else if (*last != stage) {
      *last = std::string(stage);
      std::fprintf(stderr, "%.*s...\n", static_cast<int>(stage.size()), stage.data());
    }
    std::fflush(stderr);
  };
}

}  // namespace facecast::cli
