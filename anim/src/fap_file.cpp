// The FBA ASCII FAP file: parse (bounded, every error names the line) and write.
#include <charconv>
#include <cmath>
#include <cstdio>

#include "facecast/anim/fap.hpp"
#include "facecast/core/error.hpp"

namespace facecast::anim {
namespace {

struct Token {
  std::string_view text;
  int line = 0;
};

// Whitespace-separated tokens with their line numbers; lines whose first character that is not a
// space is '#' are comments.
std::vector<Token> tokenize(std::string_view text) {
  std::vector<Token> out;
  int line = 1;
  std::size_t i = 0;
  bool line_start = true;
  while (i < text.size()) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
      ++i;
      line_start = true;
      continue;
    }
    if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
      ++i;
      continue;
    }
    if (c == '#' && line_start) {
      while (i < text.size() && text[i] != '\n') ++i;
      continue;
    }
    line_start = false;
    const std::size_t start = i;
    while (i < text.size() && text[i] != '\n' && text[i] != ' ' && text[i] != '\t' &&
           text[i] != '\r' && text[i] != '\f' && text[i] != '\v')
      ++i;
    out.push_back({text.substr(start, i - start), line});
  }
  return out;
}

class Reader {
 public:
  Reader(std::vector<Token> tokens, std::string_view what)
      : tokens_(std::move(tokens)), what_(what) {}

  bool done() const { return at_ >= tokens_.size(); }

  [[noreturn]] void fail(const std::string& problem) const {
    const int line = done() ? (tokens_.empty() ? 1 : tokens_.back().line) : tokens_[at_].line;
    throw Error(std::string(what_) + ":" + std::to_string(line) + ": " + problem);
  }

  std::string_view word(const char* field) {
    if (done()) fail(std::string("the file ends where ") + field + " should be");
    return tokens_[at_++].text;
  }

  double number(const char* field) {
    const std::string_view w = word(field);
    double v = 0;
    const auto [end, ec] = std::from_chars(w.data(), w.data() + w.size(), v);
    if (ec != std::errc() || end != w.data() + w.size() || !std::isfinite(v)) {
      --at_;
      fail(std::string(field) + ": '" + std::string(w.substr(0, 32)) + "' is not a number");
    }
    return v;
  }

  int integer(const char* field, int lo, int hi) {
    const double v = number(field);
    if (v != std::floor(v) || v < lo || v > hi) {
      --at_;
      fail(std::string(field) + ": expected a whole number in " + std::to_string(lo) + ".." +
           std::to_string(hi));
    }
    return static_cast<int>(v);
  }

 private:
  std::vector<Token> tokens_;
  std::string_view what_;
  std::size_t at_ = 0;
};

void read_values(Reader& in, FapFrame& f, const FapLimits& limits) {
  if (f.mask[0]) {
    f.viseme.select1 = in.integer("viseme_select1", 0, 14);
    f.viseme.select2 = in.integer("viseme_select2", 0, 14);
    f.viseme.blend = in.integer("viseme_blend", 0, 63);
    f.viseme.def = in.integer("viseme_def", 0, 1);
  }
  if (f.mask[1]) {
    f.expression.select1 = in.integer("expression_select1", 0, 6);
    f.expression.intensity1 = in.integer("expression_intensity1", 0, 63);
    f.expression.select2 = in.integer("expression_select2", 0, 6);
    f.expression.intensity2 = in.integer("expression_intensity2", 0, 63);
    f.expression.init_face = in.integer("init_face", 0, 1);
    f.expression.def = in.integer("expression_def", 0, 1);
  }
  for (int n = 3; n <= kFapCount; ++n) {
    if (!f.mask[static_cast<std::size_t>(n - 1)]) continue;
    const std::string field = "FAP " + std::to_string(n);
    const double v = in.number(field.c_str());
    if (std::abs(v) > limits.max_value) {
      char bound[32];
      std::snprintf(bound, sizeof bound, "%g", limits.max_value);
      in.fail(field + ": beyond +-" + bound);
    }
    f.value[static_cast<std::size_t>(n - 1)] = v;
  }
}

}  // namespace

FapSequence parse_fap(std::string_view text, std::string_view what, const FapLimits& limits) {
  if (text.size() > limits.max_bytes)
    throw Error(std::string(what) + ": " + std::to_string(text.size()) + " bytes, more than " +
                std::to_string(limits.max_bytes));
  Reader in(tokenize(text), what);
  FapSequence s;
  s.version = std::string(in.word("the header's version"));
  s.name = std::string(in.word("the header's name"));
  s.fps = in.number("the header's frame rate");
  if (!(s.fps >= 1 && s.fps <= 1000)) in.fail("frame rate: expected 1 to 1000 frames a second");
  const int frames = in.integer("the header's frame count", 0, limits.max_frames);
  if (frames / s.fps > limits.max_seconds) {
    char why[96];
    std::snprintf(why, sizeof why, "%d frames at %g fps: longer than %g s", frames, s.fps,
                  limits.max_seconds);
    in.fail(why);
  }
  s.frames.reserve(static_cast<std::size_t>(frames));
  FapFrame state;  // what every FAP holds so far
  while (!in.done()) {
    FapFrame f = state;
    f.mask.reset();
    for (int n = 0; n < kFapCount; ++n)
      f.mask[static_cast<std::size_t>(n)] = in.integer("the mask", 0, 1) == 1;
    const int index = in.integer("the frame number", 0, limits.max_frames);
    if (index >= frames)
      in.fail("frame " + std::to_string(index) + ": the header says " + std::to_string(frames) +
              " frames");
    if (index < static_cast<int>(s.frames.size())) {
      in.fail("frame " + std::to_string(index) + " comes after frame " +
              std::to_string(s.frames.size() - 1));
    }
    read_values(in, f, limits);
    // Frames the file skips repeat the one before.
    while (static_cast<int>(s.frames.size()) < index) {
      FapFrame repeat = state;
      repeat.mask.reset();
      s.frames.push_back(repeat);
    }
    state = f;
    s.frames.push_back(std::move(f));
  }
  while (static_cast<int>(s.frames.size()) < frames) {
    FapFrame repeat = state;
    repeat.mask.reset();
    s.frames.push_back(repeat);
  }
  return s;
}

std::string to_fap_text(const FapSequence& s) {
  std::string name = s.name.empty() ? "facecast" : s.name;
  for (char& c : name)
    if (static_cast<unsigned char>(c) <= ' ') c = '_';
  char buf[64];
  std::snprintf(buf, sizeof buf, " %g %zu\n", s.fps, s.frames.size());
  std::string out = (s.version.empty() ? "2.1" : s.version) + " " + name + buf;
  for (std::size_t i = 0; i < s.frames.size(); ++i) {
    const FapFrame& f = s.frames[i];
    for (int n = 0; n < kFapCount; ++n) {
      out += f.mask[static_cast<std::size_t>(n)] ? '1' : '0';
      out += n + 1 < kFapCount ? ' ' : '\n';
    }
    out += std::to_string(i);
    const auto put = [&](long v) { out += ' ' + std::to_string(v); };
    if (f.mask[0])
      for (int v : {f.viseme.select1, f.viseme.select2, f.viseme.blend, f.viseme.def}) put(v);
    if (f.mask[1])
      for (int v : {f.expression.select1, f.expression.intensity1, f.expression.select2,
                    f.expression.intensity2, f.expression.init_face, f.expression.def})
        put(v);
    for (int n = 3; n <= kFapCount; ++n)
      if (f.mask[static_cast<std::size_t>(n - 1)])
        put(std::lround(f.value[static_cast<std::size_t>(n - 1)]));
    out += '\n';
  }
  return out;
}

}  // namespace facecast::anim
