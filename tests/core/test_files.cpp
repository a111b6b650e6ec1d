// Atomic, durable writes; the sweep of temporaries a killed process left; random ids.
#include <catch2/catch.hpp>

#include <fcntl.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "facecast/core/error.hpp"
#include "facecast/core/files.hpp"
#include "facecast/core/random.hpp"

namespace fs = std::filesystem;

namespace {

fs::path fresh_dir(const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("facecast-test-" + name + "-" + facecast::random_hex(4));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::vector<std::string> names(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

TEST_CASE("write_file_atomic replaces whole files, leaves no temporary, and opens close-on-exec",
          "[files]") {
  const fs::path dir = fresh_dir("atomic");
  const fs::path f = dir / "a.json";
  facecast::write_file_atomic(f, "old");
  CHECK(facecast::read_file(f) == "old");
  // The temporary is open while the writer runs: close-on-exec, and named as a temporary.
  bool checked = false;
  facecast::write_file_atomic(f, [&](std::ostream& out) {
    out << std::string(200000, 'n');
    for (const auto& e : fs::directory_iterator("/proc/self/fd")) {
      std::error_code ec;
      const fs::path target = fs::read_symlink(e.path(), ec);
      if (ec || target.parent_path() != dir) continue;
      CHECK(facecast::is_temp_name(target.filename().string()));
      const int fd = std::stoi(e.path().filename().string());
      CHECK((::fcntl(fd, F_GETFD) & FD_CLOEXEC) != 0);
      checked = true;
    }
  });
  CHECK(checked);
  CHECK(facecast::read_file(f) == std::string(200000, 'n'));
  // A writer that throws leaves the old file and nothing else.
  CHECK_THROWS(facecast::write_file_atomic(f, [](std::ostream& out) {
    out << "half";
    throw facecast::Error("stop");
  }));
  CHECK(facecast::read_file(f).size() == 200000);
  CHECK(names(dir) == std::vector<std::string>{"a.json"});
  // commit_file moves a finished file into place.
  std::ofstream(dir / "b.tmp1") << "bee";
  facecast::commit_file(dir / "b.tmp1", dir / "b.txt");
  CHECK(facecast::read_file(dir / "b.txt") == "bee");
  CHECK_THROWS_WITH(facecast::commit_file(dir / "missing.tmp", dir / "c.txt"),
                    Catch::Matchers::Contains("missing.tmp"));
  fs::remove_all(dir);
}

TEST_CASE("sweep_temp_files removes what a killed write left and nothing else", "[files]") {
  const fs::path dir = fresh_dir("sweep");
  std::ofstream(dir / "jobs.sqlite3") << "db";
  std::ofstream(dir / "jobs.sqlite3-wal") << "wal";
  std::ofstream(dir / "meta.json.tmp123456") << "half";
  std::ofstream(dir / ".tmp-j5-77.mp4") << "half";
  fs::create_directories(dir / "r0123abcd.tmp" / "sub");
  std::ofstream(dir / "r0123abcd.tmp" / "rig.glb") << "half";
  fs::create_directories(dir / "r0123abce");
  CHECK(facecast::sweep_temp_files(dir, 3600) == 0);  // all fresh
  CHECK(facecast::sweep_temp_files(dir) == 3);
  CHECK(names(dir) == std::vector<std::string>{"jobs.sqlite3", "jobs.sqlite3-wal", "r0123abce"});
  CHECK(facecast::sweep_temp_files(dir / "missing") == 0);
  fs::remove_all(dir);
}

TEST_CASE("random ids come from the kernel and do not collide across threads", "[files][random]") {
  CHECK(facecast::random_hex(8).size() == 16);
  CHECK(facecast::random_hex(8) != facecast::random_hex(8));
  const std::string t = facecast::time_ordered_hex();
  CHECK(t.size() == 20);
  CHECK(t.find_first_not_of("0123456789abcdef") == std::string::npos);
  std::mutex m;
  std::set<std::string> seen;
  std::vector<std::thread> threads;
  for (int k = 0; k < 4; ++k)
    threads.emplace_back([&] {
      std::vector<std::string> mine;
      for (int i = 0; i < 5000; ++i) mine.push_back(facecast::time_ordered_hex());
      std::lock_guard lock(m);
      seen.insert(mine.begin(), mine.end());
    });
  for (auto& th : threads) th.join();
  CHECK(seen.size() == 20000);
}
