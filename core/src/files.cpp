#include "facecast/core/files.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <streambuf>
#include <system_error>

#include "facecast/core/error.hpp"
#include "facecast/core/random.hpp"

namespace facecast {

std::string_view to_string(ErrorCode code) noexcept {
  switch (code) {
    case ErrorCode::kInvalidInput:
      return "invalid_input";
    case ErrorCode::kNotFound:
      return "not_found";
    case ErrorCode::kUnsupported:
      return "unsupported";
    case ErrorCode::kLimit:
      return "limit";
    case ErrorCode::kInternal:
      return "internal";
  }
  return "internal";
}

namespace {

namespace fs = std::filesystem;

std::string errno_text() {
  return std::strerror(errno);
}

// A descriptor closed on every path.
struct Fd {
  int fd = -1;
  explicit Fd(int f) : fd(f) {}
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
};

// An output stream buffer over a descriptor; a failed write makes the stream bad (errno kept).
class FdBuf final : public std::streambuf {
 public:
  explicit FdBuf(int fd) : fd_(fd) { setp(buf_.data(), buf_.data() + buf_.size()); }
  int error() const { return error_; }

 protected:
  int_type overflow(int_type c) override {
    if (flush_buffer() != 0) return traits_type::eof();
    if (!traits_type::eq_int_type(c, traits_type::eof())) {
      *pptr() = traits_type::to_char_type(c);
      pbump(1);
    }
    return traits_type::not_eof(c);
  }
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    if (n >= static_cast<std::streamsize>(buf_.size())) {  // large: straight through
      if (flush_buffer() != 0 || !write_all(s, static_cast<std::size_t>(n))) return 0;
      return n;
    }
    return std::streambuf::xsputn(s, n);
  }
  int sync() override { return flush_buffer(); }

 private:
  int flush_buffer() {
    const auto n = static_cast<std::size_t>(pptr() - pbase());
    if (n > 0 && !write_all(pbase(), n)) return -1;
    setp(buf_.data(), buf_.data() + buf_.size());
    return 0;
  }
  bool write_all(const char* p, std::size_t n) {
    if (error_) return false;
    while (n > 0) {
      const ssize_t w = ::write(fd_, p, n);
      if (w < 0) {
        if (errno == EINTR) continue;
        error_ = errno;
        return false;
      }
      p += w;
      n -= static_cast<std::size_t>(w);
    }
    return true;
  }
  int fd_;
  int error_ = 0;
  std::array<char, 65536> buf_{};
};

}  // namespace

std::string read_file(const fs::path& path) {
  const Fd in(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
  if (in.fd < 0) throw Error(path.string() + ": cannot open file", ErrorCode::kNotFound);
  std::string out;
  std::array<char, 65536> buf;
  for (;;) {
    const ssize_t n = ::read(in.fd, buf.data(), buf.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      // A folder opens but does not read: the same "cannot open" as before.
      if (errno == EISDIR) throw Error(path.string() + ": cannot open file", ErrorCode::kNotFound);
      throw Error(path.string() + ": read error: " + errno_text(), ErrorCode::kInternal);
    }
    if (n == 0) break;
    out.append(buf.data(), static_cast<std::size_t>(n));
  }
  return out;
}

fs::path temp_sibling(const fs::path& path) {
  auto tmp = path;
  tmp += ".tmp" + random_hex(6);
  return tmp;
}

bool is_temp_name(std::string_view name) {
  return name.find(".tmp") != std::string_view::npos;
}

void fsync_path(const fs::path& path) {
  const Fd f(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
  if (f.fd < 0 || (::fsync(f.fd) != 0 && errno != EINVAL && errno != EROFS))
    throw Error(path.string() + ": cannot flush to disk: " + errno_text(), ErrorCode::kInternal);
}

void commit_file(const fs::path& from, const fs::path& to) {
  fsync_path(from);
  std::error_code ec;
  fs::rename(from, to, ec);
  if (ec) throw Error(to.string() + ": cannot rename: " + ec.message(), ErrorCode::kInternal);
  const fs::path dir = to.has_parent_path() ? to.parent_path() : fs::path(".");
  fsync_path(dir);
}

void write_file_atomic(const fs::path& path, const std::function<void(std::ostream&)>& write) {
  if (path.has_parent_path()) {
    std::error_code ec;
    fs::create_directories(path.parent_path(), ec);
    if (ec)
      throw Error(path.string() + ": cannot create folder: " + ec.message(), ErrorCode::kInternal);
  }
  const auto tmp = temp_sibling(path);
  try {
    {
      const Fd out(::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666));
      if (out.fd < 0)
        throw Error(path.string() + ": cannot write file: " + errno_text(), ErrorCode::kInternal);
      FdBuf buf(out.fd);
      std::ostream stream(&buf);
      write(stream);
      stream.flush();
      if (!stream || buf.error()) {
        throw Error(path.string() + ": write error" +
                        (buf.error() ? std::string(": ") + std::strerror(buf.error()) : ""),
                    ErrorCode::kInternal);
      }
      if (::fsync(out.fd) != 0 && errno != EINVAL)
        throw Error(path.string() + ": cannot flush to disk: " + errno_text(),
                    ErrorCode::kInternal);
    }
    std::error_code ec;
    fs::rename(tmp, path, ec);
    if (ec) throw Error(path.string() + ": cannot rename: " + ec.message(), ErrorCode::kInternal);
    fsync_path(path.has_parent_path() ? path.parent_path() : fs::path("."));
  } catch (...) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw;
  }
}

void write_file_atomic(const fs::path& path, std::string_view bytes) {
  write_file_atomic(path, [&](std::ostream& out) {
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  });
}

std::size_t sweep_temp_files(const fs::path& dir, double min_age) {
  std::size_t removed = 0;
  std::error_code ec;
  const auto now = fs::file_time_type::clock::now();
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const fs::path p = it->path();
    if (!is_temp_name(p.filename().string())) continue;
    std::error_code e;
    if (min_age > 0) {
      const auto changed = fs::last_write_time(p, e);
      if (e || std::chrono::duration<double>(now - changed).count() < min_age) continue;
    }
    if (fs::remove_all(p, e) > 0 && !e) ++removed;
  }
  if (removed > 0) {
    try {
      fsync_path(dir);
    } catch (const Error&) {  // best effort: the entries are gone either way
    }
  }
  return removed;
}

}  // namespace facecast
