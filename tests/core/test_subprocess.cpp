// The subprocess helper: no pipe deadlock, a wall-clock limit that kills and reaps, bounded
// output, and children that see no descriptor or secret of the parent.
#include <catch2/catch.hpp>

#include <fcntl.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <thread>

#include "facecast/core/error.hpp"
#include "facecast/core/subprocess.hpp"

using Catch::Matchers::Contains;
using facecast::ChildFd;
using facecast::run_subprocess;
using facecast::RunOptions;

namespace {

using Clock = std::chrono::steady_clock;

double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

std::set<std::string> lines(const std::string& text) {
  std::set<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);)
    if (!l.empty()) out.insert(l);
  return out;
}

// Whether a process is gone or a zombie nobody reaped yet (a container's init may not reap).
bool dead(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string s;
  if (!std::getline(stat, s)) return true;
  const auto paren = s.rfind(')');
  return paren != std::string::npos && paren + 2 < s.size() && s[paren + 2] == 'Z';
}

}  // namespace

TEST_CASE("a child that fills stderr before its stdout ends does not deadlock", "[subprocess]") {
  // 1 MB of stderr (16 pipe buffers) before stdout: reading stdout to its end first would wait
  // forever for a child blocked on a full stderr pipe.
  RunOptions o;
  o.timeout = 20;
  o.max_error = 4096;
  const auto t0 = Clock::now();
  const auto r =
      run_subprocess({"/bin/sh", "-c",
                      "head -c 1048576 /dev/zero | tr '\\0' x >&2; echo >&2; echo 'last line' >&2; "
                      "echo done"},
                     o);
  CHECK(since(t0) < 10);
  CHECK(r.ok());
  CHECK(r.out == "done\n");
  CHECK(r.err.size() <= 4096);
  CHECK(r.last_error_line() == "last line");
  CHECK_FALSE(r.status.timed_out);
}

TEST_CASE("input and output flow together: 8 MB through cat", "[subprocess]") {
  // Writing all input before reading any output blocks once cat's output pipe is full.
  std::string input(8 << 20, '\0');
  for (std::size_t i = 0; i < input.size(); ++i) input[i] = static_cast<char>('a' + i % 26);
  RunOptions o;
  o.input = input;
  o.timeout = 20;
  const auto r = run_subprocess({"cat"}, o);
  CHECK(r.ok());
  CHECK(r.out.size() == input.size());
  CHECK(r.out == input);
}

TEST_CASE("a child past its time limit is killed with its process group and reaped",
          "[subprocess]") {
  RunOptions o;
  o.timeout = 1;
  auto t0 = Clock::now();
  auto r = run_subprocess({"sleep", "30"}, o);
  CHECK(since(t0) < o.timeout + 1);
  CHECK(r.status.timed_out);
  CHECK(r.status.signal == SIGKILL);
  CHECK_FALSE(r.ok());
  CHECK(r.describe() == "sleep was stopped after the time limit of 1 s");

  // A grandchild that holds stdout open (and ignores SIGTERM) goes with it.
  t0 = Clock::now();
  r = run_subprocess({"/bin/sh", "-c", "trap '' TERM; sleep 30 & echo $!; wait"}, o);
  CHECK(since(t0) < o.timeout + 1);
  CHECK(r.status.timed_out);
  const pid_t grandchild = std::atoi(r.out.c_str());
  REQUIRE(grandchild > 0);
  bool gone = false;
  for (int i = 0; i < 100 && !gone; ++i) {
    gone = dead(grandchild);
    if (!gone) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  CHECK(gone);
}

TEST_CASE("the child sees only 0, 1 and 2 of the parent's descriptors", "[subprocess]") {
  // Descriptors without close-on-exec, as a library or an accepted socket may leave them.
  const int file = ::open("/dev/null", O_RDONLY);
  const int sock = ::socket(AF_INET, SOCK_STREAM, 0);
  int p[2];
  REQUIRE(::pipe(p) == 0);
  const int high = ::fcntl(file, F_DUPFD, 200);
  REQUIRE(file >= 3);
  REQUIRE(sock >= 3);
  REQUIRE(high >= 200);
  // The shell lists its own descriptors (ls runs in a child of it, with the same ones).
  const auto r = run_subprocess({"/bin/sh", "-c", "ls /proc/$$/fd"});
  for (const int fd : {file, sock, p[0], p[1], high}) ::close(fd);
  INFO(r.out << r.err);
  REQUIRE(r.ok());
  CHECK(lines(r.out) == std::set<std::string>{"0", "1", "2"});

  // The long-lived form: exactly the descriptors given, wired as asked (3 from a pipe). (The
  // listing comes before any redirection: dash keeps a saved copy of a redirected descriptor.)
  facecast::Child child({"/bin/sh", "-c", "ls /proc/$$/fd; cat <&3; cat"},
                        {{0, ChildFd::Kind::kWrite},
                         {3, ChildFd::Kind::kWrite},
                         {1, ChildFd::Kind::kRead, -1, 1 << 20, false},
                         {2, ChildFd::Kind::kRead}});
  CHECK(child.write(3, "three ", 5));
  child.close_pipe(3);
  CHECK(child.write(0, "zero", 5));
  const auto status = child.finish(10);
  CHECK(status.ok());
  CHECK(child.output(1) == "0\n1\n2\n3\nthree zero");
}

TEST_CASE("the child gets an allow-listed environment", "[subprocess]") {
  ::setenv("FACECAST_TOKEN", "secret-token-123", 1);
  const auto r = run_subprocess({"env"});
  ::unsetenv("FACECAST_TOKEN");
  REQUIRE(r.ok());
  CHECK(r.out.find("secret-token-123") == std::string::npos);
  CHECK(r.out.find("PATH=") != std::string::npos);
}

TEST_CASE("output is bounded and failures name the program and its last stderr line",
          "[subprocess]") {
  RunOptions o;
  o.max_output = 1 << 20;
  o.timeout = 20;
  const auto t0 = Clock::now();
  auto r = run_subprocess({"cat", "/dev/zero"}, o);  // endless
  CHECK(since(t0) < 5);
  CHECK(r.output_limited);
  CHECK(r.out.size() == o.max_output);
  CHECK_FALSE(r.ok());
  CHECK_THAT(r.describe(), Contains("cat wrote more than 1048576 bytes"));

  r = run_subprocess(
      {"/bin/sh", "-c", "echo first >&2; printf 'the \\033[1mlast\\r\\n\\n' >&2; exit 3"});
  CHECK(r.status.code == 3);
  CHECK(r.last_error_line() == "the [1mlast");
  CHECK(r.describe() == "sh failed (exit 3): the [1mlast");

  r = run_subprocess({"/bin/sh", "-c", "kill -SEGV $$"});
  CHECK(r.status.signal == SIGSEGV);
  CHECK_THAT(r.describe(), Contains("sh was killed by signal 11"));

  CHECK_THROWS_WITH(run_subprocess({"facecast-no-such-program"}),
                    Contains("cannot run 'facecast-no-such-program'") && Contains("No such file"));
}

TEST_CASE("a child that stops reading its input is no SIGPIPE for the parent", "[subprocess]") {
  RunOptions o;
  o.input = std::string(4 << 20, 'x');
  o.timeout = 10;
  const auto r = run_subprocess({"/bin/sh", "-c", "exec 0<&-; echo closed"}, o);
  CHECK(r.ok());
  CHECK(r.out == "closed\n");
  // A file as stdin.
  char name[] = "/tmp/facecast-subprocess-XXXXXX";
  const int fd = ::mkstemp(name);
  REQUIRE(fd >= 0);
  REQUIRE(::write(fd, "from a file", 11) == 11);
  ::close(fd);
  o.input.clear();
  o.input_file = name;
  const auto f = run_subprocess({"cat"}, o);
  ::unlink(name);
  CHECK(f.out == "from a file");
}

TEST_CASE("a destroyed Child leaves no process behind", "[subprocess]") {
  pid_t pid;
  {
    facecast::Child child({"sleep", "30"});
    pid = child.pid();
    CHECK_FALSE(child.try_wait());
  }
  CHECK(dead(pid));
  facecast::Child quick({"true"});
  std::optional<facecast::ExitStatus> s;
  for (int i = 0; i < 500 && !s; ++i) {
    s = quick.try_wait();
    if (!s) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  REQUIRE(s);
  CHECK(s->ok());
}
