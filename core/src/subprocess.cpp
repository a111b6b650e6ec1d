#include "facecast/core/subprocess.hpp"

#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <utility>

#include "facecast/core/error.hpp"

extern char** environ;

// posix_spawn can close every inherited descriptor from glibc 2.34 on; elsewhere fork + exec.
#if defined(__GLIBC__) && !defined(FACECAST_SPAWN_FORK)
#if __GLIBC_PREREQ(2, 34)
#define FACECAST_POSIX_SPAWN 1
#endif
#endif

namespace facecast {
namespace {

using Clock = std::chrono::steady_clock;

std::string errno_text(int e) {
  return std::strerror(e);
}

std::string base_name(const std::string& path) {
  const auto slash = path.rfind('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

int ms_until(Clock::time_point t) {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(t - Clock::now()).count();
  return static_cast<int>(std::clamp<long long>(ms, 0, 1000000));
}

Clock::time_point after(double seconds) {
  if (!(seconds < 1e7)) seconds = 1e7;  // "no limit" (and NaN) as about four months
  return Clock::now() +
         std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
}

// SIGPIPE blocked in this thread while writing to a child (EPIPE instead), and one raised by
// those writes consumed before the mask is restored.
class SigpipeBlock {
 public:
  SigpipeBlock() {
    sigemptyset(&set_);
    sigaddset(&set_, SIGPIPE);
    pthread_sigmask(SIG_BLOCK, &set_, &old_);
    sigset_t pending;
    sigpending(&pending);
    was_pending_ = sigismember(&pending, SIGPIPE) == 1;
  }
  ~SigpipeBlock() {
    if (!was_pending_) {
      sigset_t pending;
      sigpending(&pending);
      if (sigismember(&pending, SIGPIPE) == 1) {
        const timespec zero{0, 0};
        while (sigtimedwait(&set_, nullptr, &zero) < 0 && errno == EINTR) {
        }
      }
    }
    pthread_sigmask(SIG_SETMASK, &old_, nullptr);
  }
  SigpipeBlock(const SigpipeBlock&) = delete;
  SigpipeBlock& operator=(const SigpipeBlock&) = delete;

 private:
  sigset_t set_{}, old_{};
  bool was_pending_ = false;
};

// The environment a child gets: what a program needs to run and find its libraries, nothing
// the server holds (FACECAST_TOKEN, passwords, cloud keys).
std::vector<std::string> child_environment() {
  static constexpr const char* kKeep[] = {
      "PATH=", "HOME=", "USER=", "LANG=", "LANGUAGE=", "TZ=", "TMPDIR=", "LD_LIBRARY_PATH="};
  std::vector<std::string> out;
  for (char** e = environ; e && *e; ++e) {
    const std::string_view v(*e);
    bool keep = v.starts_with("LC_");
    for (const char* k : kKeep) keep = keep || v.starts_with(k);
    if (keep) out.emplace_back(v);
  }
  return out;
}

std::vector<char*> pointers(std::vector<std::string>& strings) {
  std::vector<char*> out;
  for (auto& s : strings) out.push_back(s.data());
  out.push_back(nullptr);
  return out;
}

void read_wait_status(int status, ExitStatus& out) {
  if (WIFEXITED(status)) {
    out.code = WEXITSTATUS(status);
  } else if (WIFSIGNALED(status)) {
    out.signal = WTERMSIG(status);
  }
}

#ifndef FACECAST_POSIX_SPAWN
// argv[0] as execvp would find it, resolved before fork (execvp is not async-signal-safe).
std::string resolve_program(const std::string& name, const std::vector<std::string>& env) {
  if (name.find('/') != std::string::npos) return name;
  std::string path = "/usr/local/bin:/usr/bin:/bin";
  for (const auto& e : env)
    if (e.starts_with("PATH=")) path = e.substr(5);
  const std::string_view all(path);
  std::size_t start = 0;
  for (;;) {
    const auto colon = all.find(':', start);
    const std::string_view dir =
        all.substr(start, colon == std::string_view::npos ? colon : colon - start);
    std::string candidate(dir.empty() ? std::string_view(".") : dir);
    candidate.push_back('/');
    candidate.append(name);
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
    if (colon == std::string_view::npos) break;
    start = colon + 1;
  }
  return name;  // execve fails with ENOENT
}
#endif

// Starts the child; `map` holds (parent descriptor, child descriptor) pairs whose parent
// descriptors are all above every child descriptor, so no dup2 overwrites a later source.
pid_t start_child(const std::vector<std::string>& argv_in,
                  const std::vector<std::pair<int, int>>& map, int first_closed) {
  std::vector<std::string> args = argv_in;
  std::vector<std::string> env = child_environment();
  std::vector<char*> argv = pointers(args);
  std::vector<char*> envp = pointers(env);
#ifdef FACECAST_POSIX_SPAWN
  posix_spawn_file_actions_t actions;
  posix_spawnattr_t attr;
  posix_spawn_file_actions_init(&actions);
  posix_spawnattr_init(&attr);
  int rc = 0;
  for (const auto& [from, to] : map)
    if (rc == 0) rc = posix_spawn_file_actions_adddup2(&actions, from, to);
  if (rc == 0) rc = posix_spawn_file_actions_addclosefrom_np(&actions, first_closed);
  sigset_t none, all;
  sigemptyset(&none);
  sigfillset(&all);
  if (rc == 0)
    rc = posix_spawnattr_setflags(
        &attr, POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
  if (rc == 0) rc = posix_spawnattr_setpgroup(&attr, 0);
  if (rc == 0) rc = posix_spawnattr_setsigmask(&attr, &none);
  if (rc == 0) rc = posix_spawnattr_setsigdefault(&attr, &all);
  pid_t pid = -1;
  if (rc == 0) rc = posix_spawnp(&pid, argv[0], &actions, &attr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);
  if (rc != 0) {
    throw Error("cannot run '" + argv_in[0] + "': " + errno_text(rc), ErrorCode::kInternal);
  }
  return pid;
#else
  // Everything is prepared here: between fork and exec only async-signal-safe calls run.
  const std::string program = resolve_program(argv_in[0], env);
  rlimit rl{};
  const int max_fd =
      getrlimit(RLIMIT_NOFILE, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY && rl.rlim_cur < 65536
          ? static_cast<int>(rl.rlim_cur)
          : 65536;
  int report[2];  // the child's exec errno, or EOF once exec succeeded
  if (pipe2(report, O_CLOEXEC) != 0)
    throw Error("cannot run '" + argv_in[0] + "': pipe: " + errno_text(errno),
                ErrorCode::kInternal);
  sigset_t all, old;
  sigfillset(&all);
  pthread_sigmask(SIG_SETMASK, &all, &old);  // no handler of ours runs in the child
  const pid_t pid = fork();
  if (pid == 0) {
    setpgid(0, 0);
    struct sigaction dfl {};
    dfl.sa_handler = SIG_DFL;
    for (int sig = 1; sig < NSIG; ++sig) sigaction(sig, &dfl, nullptr);
    // The report pipe's write end must survive the dups: move it above everything.
    const int rep = fcntl(report[1], F_DUPFD_CLOEXEC, first_closed + 1);
    for (const auto& [from, to] : map) dup2(from, to);
    int e = 0;
#ifdef SYS_close_range
    if (rep >= 0) {
      if (first_closed < rep) syscall(SYS_close_range, first_closed, rep - 1, 0);
      e = static_cast<int>(syscall(SYS_close_range, rep + 1, ~0U, 0));
    }
#else
    e = -1;
#endif
    if (e != 0)
      for (int fd = first_closed; fd < max_fd; ++fd)
        if (fd != rep) close(fd);
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);
    execve(program.c_str(), argv.data(), envp.data());
    e = errno;
    if (rep >= 0) (void)!::write(rep, &e, sizeof e);
    _exit(127);
  }
  const int fork_errno = errno;
  if (pid > 0) setpgid(pid, pid);  // also here: kill(-pid) must reach it whichever runs first
  pthread_sigmask(SIG_SETMASK, &old, nullptr);
  close(report[1]);
  if (pid < 0) {
    close(report[0]);
    throw Error("cannot run '" + argv_in[0] + "': fork: " + errno_text(fork_errno),
                ErrorCode::kInternal);
  }
  int child_errno = 0;
  ssize_t n;
  while ((n = ::read(report[0], &child_errno, sizeof child_errno)) < 0 && errno == EINTR) {
  }
  close(report[0]);
  if (n == static_cast<ssize_t>(sizeof child_errno)) {
    int status;
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    throw Error("cannot run '" + argv_in[0] + "': " + errno_text(child_errno),
                ErrorCode::kInternal);
  }
  return pid;
#endif
}

int open_pidfd(pid_t pid) {
#ifdef SYS_pidfd_open
  const long fd = syscall(SYS_pidfd_open, pid, 0);
  return fd >= 0 ? static_cast<int>(fd) : -1;
#else
  (void)pid;
  return -1;
#endif
}

}  // namespace

bool set_cloexec(int fd) noexcept {
  const int flags = fcntl(fd, F_GETFD);
  return flags >= 0 && fcntl(fd, F_SETFD, flags | FD_CLOEXEC) == 0;
}

// ---- Child --------------------------------------------------------------------------------------

Child::Child(const std::vector<std::string>& argv, const std::vector<ChildFd>& fds_in) {
  if (argv.empty() || argv[0].empty()) throw Error("subprocess: no program", ErrorCode::kInternal);
  program_ = base_name(argv[0]);
  std::vector<ChildFd> fds = fds_in;
  int top = 2;
  for (const auto& f : fds) {
    if (f.target < 0 || f.target > 1023)
      throw Error("subprocess: descriptor " + std::to_string(f.target) + " is out of range",
                  ErrorCode::kInternal);
    for (const auto& g : fds)
      if (&g != &f && g.target == f.target)
        throw Error("subprocess: descriptor " + std::to_string(f.target) + " given twice",
                    ErrorCode::kInternal);
    top = std::max(top, f.target);
  }
  for (int t = 0; t <= 2; ++t)
    if (std::none_of(fds.begin(), fds.end(), [&](const ChildFd& f) { return f.target == t; }))
      fds.push_back(ChildFd{t, ChildFd::Kind::kNull});
  const int high = top + 1;  // the child's descriptors are 0..top; everything from high is closed

  std::vector<std::pair<int, int>> map;  // parent copies (>= high) -> child descriptors
  const auto cleanup_map = [&] {
    for (const auto& m : map) ::close(m.first);
  };
  try {
    for (const auto& f : fds) {
      int child_end = -1;
      bool owned = true;  // child_end is ours to close after the copy
      switch (f.kind) {
        case ChildFd::Kind::kNull:
          child_end = ::open("/dev/null", O_RDWR | O_CLOEXEC);
          if (child_end < 0)
            throw Error("cannot run '" + argv[0] + "': /dev/null: " + errno_text(errno),
                        ErrorCode::kInternal);
          break;
        case ChildFd::Kind::kWrite:
        case ChildFd::Kind::kRead: {
          int p[2];
          if (pipe2(p, O_CLOEXEC) != 0)
            throw Error("cannot run '" + argv[0] + "': pipe: " + errno_text(errno),
                        ErrorCode::kInternal);
          const bool to_child = f.kind == ChildFd::Kind::kWrite;
          child_end = to_child ? p[0] : p[1];
          const int parent_end = to_child ? p[1] : p[0];
          fcntl(parent_end, F_SETFL, fcntl(parent_end, F_GETFL) | O_NONBLOCK);
          pipes_.push_back(Pipe{f.target, parent_end, f.kind, f.limit, f.tail, false, {}});
          break;
        }
        case ChildFd::Kind::kFd:
          child_end = f.fd;
          owned = false;
          break;
      }
      const int copy = fcntl(child_end, F_DUPFD_CLOEXEC, high);
      const int copy_errno = errno;
      if (owned) ::close(child_end);
      if (copy < 0)
        throw Error("cannot run '" + argv[0] + "': descriptor " + std::to_string(f.target) + ": " +
                        errno_text(copy_errno),
                    ErrorCode::kInternal);
      map.emplace_back(copy, f.target);
    }
    pid_ = start_child(argv, map, high);
  } catch (...) {
    cleanup_map();
    for (auto& p : pipes_) ::close(p.fd);
    pipes_.clear();
    throw;
  }
  cleanup_map();
  pidfd_ = open_pidfd(pid_);
}

Child::Child(Child&& o) noexcept
    : program_(std::move(o.program_)),
      pid_(std::exchange(o.pid_, -1)),
      pidfd_(std::exchange(o.pidfd_, -1)),
      pipes_(std::move(o.pipes_)),
      status_(std::move(o.status_)) {
  o.pipes_.clear();
}

Child& Child::operator=(Child&& o) noexcept {
  if (this != &o) {
    release();
    program_ = std::move(o.program_);
    pid_ = std::exchange(o.pid_, -1);
    pidfd_ = std::exchange(o.pidfd_, -1);
    pipes_ = std::move(o.pipes_);
    o.pipes_.clear();
    status_ = std::move(o.status_);
  }
  return *this;
}

Child::~Child() {
  release();
}

void Child::release() {
  if (pid_ > 0 && !status_) kill();
  for (auto& p : pipes_)
    if (p.fd >= 0) ::close(p.fd);
  pipes_.clear();
  if (pidfd_ >= 0) ::close(pidfd_);
  pidfd_ = -1;
  pid_ = -1;
}

int Child::pipe_fd(int target) const {
  for (const auto& p : pipes_)
    if (p.target == target) return p.fd;
  return -1;
}

void Child::close_pipe(int target) {
  for (auto& p : pipes_) {
    if (p.target == target && p.fd >= 0) {
      ::close(p.fd);
      p.fd = -1;
    }
  }
}

const std::string& Child::output(int target) const {
  static const std::string none;
  for (const auto& p : pipes_)
    if (p.target == target) return p.data;
  return none;
}

bool Child::overflowed(int target) const {
  for (const auto& p : pipes_)
    if (p.target == target) return p.overflow;
  return false;
}

bool Child::any_overflow() const {
  return std::any_of(pipes_.begin(), pipes_.end(), [](const Pipe& p) { return p.overflow; });
}

bool Child::reading() const {
  return std::any_of(pipes_.begin(), pipes_.end(),
                     [](const Pipe& p) { return p.kind == ChildFd::Kind::kRead && p.fd >= 0; });
}

// Reads until the pipe is empty for now; false at its end (then it is closed).
bool Child::read_some(Pipe& p) {
  char buf[65536];
  for (;;) {
    const ssize_t n = ::read(p.fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return true;
    if (n <= 0) {
      ::close(p.fd);
      p.fd = -1;
      return false;
    }
    const auto got = static_cast<std::size_t>(n);
    if (p.tail) {
      p.data.append(buf, got);
      if (p.data.size() > 2 * p.limit + sizeof buf) p.data.erase(0, p.data.size() - p.limit);
    } else {
      const std::size_t room = p.limit - std::min(p.limit, p.data.size());
      p.data.append(buf, std::min(room, got));
      if (got > room) {
        p.overflow = true;
        return true;
      }
    }
  }
}

void Child::drain() {
  for (auto& p : pipes_)
    if (p.kind == ChildFd::Kind::kRead && p.fd >= 0 && !p.overflow) read_some(p);
}

void Child::pump(int wait_ms, int write_target, std::string_view* data) {
  std::vector<pollfd> fds;
  std::vector<Pipe*> who;
  for (auto& p : pipes_) {
    if (p.fd < 0 || p.overflow) continue;
    if (p.kind == ChildFd::Kind::kRead) {
      fds.push_back(pollfd{p.fd, POLLIN, 0});
      who.push_back(&p);
    } else if (p.target == write_target && data && !data->empty()) {
      fds.push_back(pollfd{p.fd, POLLOUT, 0});
      who.push_back(&p);
    }
  }
  // Without a pidfd the child's exit is noticed by polling its status every 20 ms.
  if (pidfd_ >= 0 && !status_) {
    fds.push_back(pollfd{pidfd_, POLLIN, 0});
    who.push_back(nullptr);
  } else {
    wait_ms = std::min(wait_ms, 20);
  }
  const int n = ::poll(fds.data(), fds.size(), wait_ms);
  if (n <= 0) return;
  for (std::size_t i = 0; i < fds.size(); ++i) {
    Pipe* p = who[i];
    if (!p || fds[i].revents == 0 || p->fd < 0) continue;
    if (p->kind == ChildFd::Kind::kRead) {
      read_some(*p);
    } else {
      for (;;) {
        const ssize_t w = ::write(p->fd, data->data(), data->size());
        if (w < 0 && errno == EINTR) continue;
        if (w < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
        if (w < 0) {  // EPIPE: the child closed its input (or ended)
          ::close(p->fd);
          p->fd = -1;
          break;
        }
        data->remove_prefix(static_cast<std::size_t>(w));
        if (data->empty()) break;
      }
    }
  }
}

bool Child::write(int target, std::string_view data, double stall_timeout) {
  const SigpipeBlock no_sigpipe;
  auto stall_until = after(stall_timeout);
  while (!data.empty()) {
    if (pipe_fd(target) < 0 || any_overflow()) return false;
    if (Clock::now() >= stall_until) return false;
    const std::size_t before = data.size();
    pump(std::max(1, ms_until(stall_until)), target, &data);
    if (data.size() < before) stall_until = after(stall_timeout);
    if (!data.empty() && exited()) return false;
  }
  return true;
}

bool Child::exited() {
  if (status_) return true;
  siginfo_t info{};
  return waitid(P_PID, static_cast<id_t>(pid_), &info, WEXITED | WNOHANG | WNOWAIT) == 0 &&
         info.si_pid == pid_;
}

ExitStatus Child::reap(bool timed_out) {
  if (status_) return *status_;
  // The group first (a grandchild that kept a pipe open), while the pid is still the group's.
  ::kill(-pid_, SIGKILL);
  int status = 0;
  pid_t r;
  while ((r = waitpid(pid_, &status, 0)) < 0 && errno == EINTR) {
  }
  ExitStatus out;
  if (r == pid_) read_wait_status(status, out);
  out.timed_out = timed_out;
  status_ = out;
  for (auto& p : pipes_) {
    if (p.kind == ChildFd::Kind::kWrite && p.fd >= 0) {
      ::close(p.fd);
      p.fd = -1;
    }
    if (p.tail && p.data.size() > p.limit) p.data.erase(0, p.data.size() - p.limit);
  }
  return out;
}

ExitStatus Child::kill() {
  if (status_) return *status_;
  if (pid_ <= 0) return ExitStatus{};
  ::kill(-pid_, SIGKILL);
  ::kill(pid_, SIGKILL);
  drain();
  return reap(false);
}

std::optional<ExitStatus> Child::try_wait() {
  if (status_) return status_;
  if (pid_ <= 0 || !exited()) return std::nullopt;
  drain();
  return reap(false);
}

ExitStatus Child::finish(double timeout) {
  if (status_) return *status_;
  const auto deadline = after(timeout);
  for (auto& p : pipes_) {
    if (p.kind == ChildFd::Kind::kWrite && p.fd >= 0) {
      ::close(p.fd);
      p.fd = -1;
    }
  }
  for (;;) {
    if (any_overflow()) {
      ::kill(-pid_, SIGKILL);
      return reap(false);
    }
    if (exited()) {
      drain();  // what it wrote before it ended
      return reap(false);
    }
    if (Clock::now() >= deadline) {
      ::kill(-pid_, SIGKILL);
      ::kill(pid_, SIGKILL);
      drain();
      return reap(true);
    }
    if (reading()) {
      pump(std::max(1, ms_until(deadline)), -1, nullptr);
    } else if (pidfd_ >= 0) {
      pollfd p{pidfd_, POLLIN, 0};
      ::poll(&p, 1, std::max(1, ms_until(deadline)));
    } else {
      const timespec pause{0, 10 * 1000 * 1000};
      nanosleep(&pause, nullptr);
    }
  }
}

}  // namespace facecast
