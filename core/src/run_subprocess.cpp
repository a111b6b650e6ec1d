// run_subprocess: a child run to completion with its input written and its outputs collected
// (the Child of subprocess.cpp does the work), and how a result reads in one line.
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <optional>

#include "facecast/core/error.hpp"
#include "facecast/core/subprocess.hpp"

namespace facecast {

using std::chrono::steady_clock;

std::string RunResult::last_error_line() const {
  std::string line;
  std::size_t end = err.size();
  while (end > 0) {
    const std::size_t start = err.rfind('\n', end - 1);
    const std::size_t from = start == std::string::npos ? 0 : start + 1;
    std::string candidate = err.substr(from, end - from);
    std::erase_if(candidate, [](char c) {
      return static_cast<unsigned char>(c) < 0x20 || c == 0x7f;  // \r, escapes, tabs
    });
    if (candidate.find_first_not_of(' ') != std::string::npos) {
      line = std::move(candidate);
      break;
    }
    if (start == std::string::npos) break;
    end = start;
  }
  if (line.size() > 300) line = line.substr(0, 297) + "...";
  return line;
}

std::string RunResult::describe() const {
  const std::string why = last_error_line();
  const std::string tail = why.empty() ? std::string() : ": " + why;
  char limit[32];
  std::snprintf(limit, sizeof limit, "%g", timeout);
  if (status.timed_out) return program + " was stopped after the time limit of " + limit + " s";
  if (output_limited)
    return program + " wrote more than " + std::to_string(out.size()) + " bytes" + tail;
  if (status.signal != 0)
    return program + " was killed by signal " + std::to_string(status.signal) + " (" +
           strsignal(status.signal) + ")" + tail;
  return program + " failed (exit " + std::to_string(status.code) + ")" + tail;
}

RunResult run_subprocess(const std::vector<std::string>& argv, const RunOptions& o) {
  const auto t0 = steady_clock::now();
  int input_fd = -1;
  if (!o.input_file.empty()) {
    input_fd = ::open(o.input_file.c_str(), O_RDONLY | O_CLOEXEC);
    if (input_fd < 0)
      throw Error(o.input_file.string() + ": cannot open: " + std::strerror(errno),
                  ErrorCode::kNotFound);
  }
  std::vector<ChildFd> fds;
  if (input_fd >= 0)
    fds.push_back(ChildFd{0, ChildFd::Kind::kFd, input_fd});
  else if (!o.input.empty())
    fds.push_back(ChildFd{0, ChildFd::Kind::kWrite});
  fds.push_back(ChildFd{1, ChildFd::Kind::kRead, -1, o.max_output, false});
  fds.push_back(ChildFd{2, ChildFd::Kind::kRead, -1, o.max_error, true});
  std::optional<Child> child;
  try {
    child.emplace(argv, fds);
  } catch (...) {
    if (input_fd >= 0) ::close(input_fd);
    throw;
  }
  if (input_fd >= 0) ::close(input_fd);

  RunResult r;
  r.program = child->program();
  r.timeout = o.timeout;
  // "No limit" (and NaN) as about four months.
  const auto deadline = t0 + std::chrono::duration_cast<steady_clock::duration>(
                                 std::chrono::duration<double>(o.timeout < 1e7 ? o.timeout : 1e7));
  if (!o.input.empty()) {
    // Input and outputs together; the time left bounds the writing.
    const double left = std::chrono::duration<double>(deadline - steady_clock::now()).count();
    child->write(0, o.input, std::max(0.0, left));
  }
  const double left = std::chrono::duration<double>(deadline - steady_clock::now()).count();
  r.status = child->finish(std::max(0.0, left));
  r.output_limited = child->overflowed(1);
  r.out = child->output(1);
  r.err = child->output(2);
  if (r.err.size() > o.max_error) r.err.erase(0, r.err.size() - o.max_error);
  r.seconds = std::chrono::duration<double>(steady_clock::now() - t0).count();
  return r;
}

}  // namespace facecast
