#pragma once
// `facecast serve` as a child process on a free port, for the server tests and the benchmarks. With
// `--port 0` the server prints its address as the first line on stdout:
//   facecast: listening on http://127.0.0.1:PORT
// The child gets SIGTERM when the thread that started it ends, so it never outlives a crash.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <optional>
#include <regex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace fctest {

class ServeProcess {
 public:
  /// Runs `exe serve --port 0 <args>` (stderr to the file `log` when given, else inherited) and
  /// waits up to `timeout` seconds for the port line. Throws std::runtime_error (the child
  /// killed) when it does not come.
  ServeProcess(const std::string& exe, std::vector<std::string> args, double timeout,
               const std::string& log = {}) {
    int out[2];
    if (pipe(out) != 0) throw std::runtime_error("pipe");
    args.insert(args.begin(), {exe, "serve", "--port", "0"});
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_ = fork();
    if (pid_ < 0) throw std::runtime_error("fork");
    if (pid_ == 0) {  // only async-signal-safe calls until exec
      prctl(PR_SET_PDEATHSIG, SIGTERM);
      dup2(out[1], 1);
      if (!log.empty()) {
        const int err = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (err >= 0) dup2(err, 2);
      }
      close(out[0]);
      execv(exe.c_str(), argv.data());
      _exit(127);
    }
    close(out[1]);
    line_ = read_line(out[0], timeout);
    close(out[0]);
    std::smatch m;
    if (!std::regex_search(line_, m, std::regex(R"(listening on http://\S+:([0-9]+))"))) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
      pid_ = -1;
      throw std::runtime_error("facecast serve printed no port line: '" + line_ + "'");
    }
    port_ = static_cast<unsigned short>(std::stoi(m[1]));
  }

  /// SIGTERM, then SIGKILL if it has not exited within 10 s (unless wait_exit() saw it exit).
  ~ServeProcess() {
    if (pid_ <= 0) return;
    kill(pid_, SIGTERM);
    if (!wait_exit(10)) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  ServeProcess(const ServeProcess&) = delete;
  ServeProcess& operator=(const ServeProcess&) = delete;

  pid_t pid() const { return pid_; }
  unsigned short port() const { return port_; }
  /// The first line the server printed.
  const std::string& line() const { return line_; }

  /// Waits up to `timeout` seconds for the child to exit; returns its waitpid status.
  std::optional<int> wait_exit(double timeout) {
    const auto t0 = std::chrono::steady_clock::now();
    do {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        return status;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    } while (std::chrono::steady_clock::now() - t0 < std::chrono::duration<double>(timeout));
    return std::nullopt;
  }

 private:
  static std::string read_line(int fd, double timeout) {
    std::string line;
    const auto t0 = std::chrono::steady_clock::now();
    while (line.find('\n') == std::string::npos &&
           std::chrono::steady_clock::now() - t0 < std::chrono::duration<double>(timeout)) {
      pollfd p{fd, POLLIN, 0};
      if (poll(&p, 1, 200) > 0) {
        char buf[256];
        const ssize_t n = read(fd, buf, sizeof buf);
        if (n <= 0) break;
        line.append(buf, static_cast<std::size_t>(n));
      }
    }
    return line;
  }

  pid_t pid_ = -1;
  unsigned short port_ = 0;
  std::string line_;
};

}  // namespace fctest
