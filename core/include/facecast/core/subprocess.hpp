#pragma once
// Child processes (ffmpeg) that cannot hang the server, leak its descriptors or block on a pipe.
//
// A child starts through posix_spawn (fork + exec with only async-signal-safe calls in between
// where posix_spawn cannot close descriptors) with exactly the descriptors it is given: 0, 1 and 2
// default to /dev/null and every other descriptor of the server (client sockets, the listening
// socket, files) is closed in the child whatever its close-on-exec flag. It runs in its own process
// group with default signal dispositions, an empty signal mask and an allow-listed environment
// (PATH, HOME, USER, LANG, LANGUAGE, LC_*, TZ, TMPDIR, LD_LIBRARY_PATH: no tokens or passwords).
// Its outputs are read through poll() together with its input being written, so a child that
// fills one pipe while the server waits on another cannot deadlock; every wait has a wall-clock
// limit after which the whole process group gets SIGKILL and the child is reaped.
//
// run_subprocess runs a command to completion (input bytes or a file in, bounded output); Child is
// the same spawn for long-lived children fed through pipes (video encoding, RTMP).
#include <sys/types.h>

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace facecast {

/// Sets FD_CLOEXEC on `fd` (for descriptors a library opened without it); false on failure.
bool set_cloexec(int fd) noexcept;

/// How one descriptor of a child is connected.
struct ChildFd {
  enum class Kind {
    kNull,   // /dev/null
    kWrite,  // a pipe the parent writes and the child reads (its stdin, or ffmpeg's "pipe:3")
    kRead,   // a pipe the child writes and the parent reads (its stdout or stderr)
    kFd,     // a copy of the parent's descriptor `fd` (a log file); the parent keeps its own
  };
  int target = 0;  // the descriptor number in the child (0..1023)
  Kind kind = Kind::kNull;
  int fd = -1;  // kFd: the parent's descriptor
  // kRead: how many bytes the parent keeps: the last `limit` bytes when `tail` (diagnostics, never
  // blocks the child), else the first `limit` (more sets overflowed()).
  std::size_t limit = 64 * 1024;
  bool tail = true;
};

/// How a child ended.
struct ExitStatus {
  int code = -1;           // its exit code, or -1 when a signal ended it
  int signal = 0;          // the signal that ended it (SIGKILL after a time limit), or 0
  bool timed_out = false;  // killed because a time limit passed
  bool ok() const { return code == 0 && !timed_out; }
};

class Child {
 public:
  /// Starts argv[0] (searched in PATH) with the descriptors `fds` (see the file comment). Throws
  /// Error(kInternal) "cannot run '<program>': <why>" when it cannot start (not found, not
  /// executable, out of processes).
  explicit Child(const std::vector<std::string>& argv, const std::vector<ChildFd>& fds = {});
  Child(Child&& other) noexcept;
  Child& operator=(Child&& other) noexcept;
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;
  /// A child still running is killed (its process group) and reaped; the pipes are closed.
  ~Child();

  pid_t pid() const { return pid_; }
  /// The program's file name (argv[0] without its folder), for messages.
  const std::string& program() const { return program_; }

  /// The parent's end of the pipe at the child's descriptor `target`, or -1 (none, or closed).
  /// The Child owns it; it does not block (O_NONBLOCK).
  int pipe_fd(int target) const;
  /// Closes the parent's end of the pipe at `target` (the child's input ends: EOF).
  void close_pipe(int target);

  /// Writes all of `data` into the kWrite pipe at `target`, reading the kRead pipes meanwhile (a
  /// child that writes much to stderr before it reads on never blocks both). False when the child
  /// closed its end (it ended), a non-tail output overflowed, or nothing could be written for
  /// `stall_timeout` seconds. SIGPIPE never reaches the process.
  bool write(int target, std::string_view data, double stall_timeout);

  /// Reads what the kRead pipes hold now, without waiting.
  void drain();

  /// Closes the input pipes, reads the outputs to their end and waits for the exit, at most
  /// `timeout` seconds in all; then the child is killed and the status says timed_out. Ends early
  /// (killing the child) when a non-tail output overflows.
  ExitStatus finish(double timeout);

  /// The exit status if the child has ended (it is reaped then), else nullopt; never blocks.
  std::optional<ExitStatus> try_wait();

  /// SIGKILL to the child's process group, then reaps it (idempotent).
  ExitStatus kill();

  /// What the child wrote to the kRead pipe at `target` (see ChildFd::limit).
  const std::string& output(int target) const;
  /// Whether the non-tail kRead pipe at `target` got more than its limit.
  bool overflowed(int target) const;

 private:
  struct Pipe {
    int target = -1;
    int fd = -1;
    ChildFd::Kind kind = ChildFd::Kind::kNull;
    std::size_t limit = 0;
    bool tail = true;
    bool overflow = false;
    std::string data;
  };
  // Waits up to `wait_ms` for output (and for `write_target` to take input); reads what came.
  void pump(int wait_ms, int write_target, std::string_view* data);
  bool read_some(Pipe& p);
  bool any_overflow() const;
  bool reading() const;
  bool exited();  // ended (not yet reaped)
  ExitStatus reap(bool timed_out);
  void release();

  std::string program_;
  pid_t pid_ = -1;
  int pidfd_ = -1;  // readable once the child exits (Linux 5.3+; else polled every 20 ms)
  std::vector<Pipe> pipes_;
  std::optional<ExitStatus> status_;
};

/// What run_subprocess gives the child and how far it lets it go.
struct RunOptions {
  std::string input;                 // written to the child's stdin, which is then closed
  std::filesystem::path input_file;  // or: stdin reads this file; neither: /dev/null
  double timeout = 60;               // wall-clock seconds, then SIGKILL to its process group
  std::size_t max_output = std::size_t{64} << 20;  // stdout bytes; more kills it (output_limited)
  std::size_t max_error = std::size_t{64} << 10;   // the last stderr bytes kept
};

struct RunResult {
  std::string program;  // argv[0]'s file name
  ExitStatus status;
  bool output_limited = false;  // stdout passed max_output: killed, `out` holds max_output bytes
  std::string out;              // stdout
  std::string err;              // the end of stderr
  double seconds = 0;           // wall-clock time it ran
  double timeout = 0;           // the limit it ran under

  bool ok() const { return status.ok() && !output_limited; }
  /// The last non-empty line of stderr, control characters removed, at most 300 bytes.
  std::string last_error_line() const;
  /// One line naming the program and why it failed: "ffmpeg failed (exit 1): <last stderr line>",
  /// "ffmpeg was stopped after the time limit of 20 s", "ffmpeg was killed by signal 11 ...",
  /// "ffmpeg wrote more than 1048576 bytes".
  std::string describe() const;
};

/// Runs argv to completion (see the file comment); throws Error(kInternal) only when it cannot
/// start: a failure of the child is in the result.
RunResult run_subprocess(const std::vector<std::string>& argv, const RunOptions& options = {});

}  // namespace facecast
