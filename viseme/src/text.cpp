// Tagged text -> text runs, expression tags and pauses.
#include "facecast/viseme/text.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>

#include "chars.hpp"
#include "facecast/core/error.hpp"
#include "tables.hpp"

namespace facecast::viseme {
namespace {

using detail::fold_width;

[[noreturn]] void fail(std::size_t offset, const std::string& why) {
  throw Error("character " + std::to_string(offset) + ": expression tag: " + why);
}

std::string lower(std::string s) {
  for (auto& c : s)
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  return s;
}

bool is_name_char(char32_t c) {
  return detail::is_ascii_alpha(c) || detail::is_ascii_digit(c) || c == '_' || c == '-';
}

// Cursor over the code points of the whole text (width-folded view for syntax).
struct Cursor {
  const std::u32string& s;
  std::size_t i;
  char32_t peek() const { return i < s.size() ? fold_width(s[i]) : 0; }
  void skip_space() {
    while (i < s.size() && detail::is_space(s[i])) ++i;
  }
};

bool known_expression(const std::string& name) {
  const auto& list = detail::tables().expressions;
  return std::find(list.begin(), list.end(), lower(name)) != list.end();
}

// Reads a number token ([+-]digits[.digits]) at the cursor; empty if none.
std::string read_number(Cursor& c) {
  std::string out;
  while (c.i < c.s.size()) {
    const char32_t ch = c.peek();
    if (detail::is_ascii_digit(ch) || ch == '.' || ((ch == '-' || ch == '+') && out.empty())) {
      out += static_cast<char>(ch);
      ++c.i;
    } else {
      break;
    }
  }
  return out;
}

// Decides whether "(" at `open` starts a tag: a known name, or name + comma + number.
bool looks_like_tag(const std::u32string& s, std::size_t open) {
  Cursor c{s, open + 1};
  c.skip_space();
  std::string name;
  while (c.i < s.size() && is_name_char(c.peek())) name += static_cast<char>(c.peek()), ++c.i;
  if (name.empty() || !detail::is_ascii_alpha(static_cast<char32_t>(name[0]))) return false;
  c.skip_space();
  if (known_expression(name))
    return c.peek() == ',' || c.peek() == ')' || c.peek() == ' ' ||
           detail::is_ascii_digit(c.peek()) || c.i >= s.size();
  if (c.peek() != ',') return false;
  ++c.i;
  c.skip_space();
  return detail::is_ascii_digit(c.peek()) || c.peek() == '-' || c.peek() == '+';
}

// Parses the tag starting at `open`; returns the piece and moves `end` past ")".
TextPiece parse_tag(const std::u32string& s, std::size_t open, std::size_t& end) {
  Cursor c{s, open + 1};
  c.skip_space();
  std::string name;
  while (c.i < s.size() && is_name_char(c.peek())) name += static_cast<char>(c.peek()), ++c.i;
  if (!known_expression(name))
    fail(open + 1,
         "unknown expression '" + name + "' (names are in configs/viseme/expressions.json)");
  const auto expect_comma = [&](const char* what) {
    c.skip_space();
    if (c.peek() != ',') fail(c.i, std::string("expected ',' before ") + what);
    ++c.i;
    c.skip_space();
  };
  expect_comma("the intensity");
  const std::size_t at_intensity = c.i;
  const std::string intensity = read_number(c);
  int value = -1;
  const auto [p, ec] =
      std::from_chars(intensity.data(), intensity.data() + intensity.size(), value);
  if (intensity.empty() || ec != std::errc() || p != intensity.data() + intensity.size())
    fail(at_intensity, "intensity must be an integer 0..63, got '" + intensity + "'");
  if (value < 0 || value > 63)
    fail(at_intensity, "intensity " + std::to_string(value) + " is outside 0..63");
  expect_comma("the ramp time");
  const std::size_t at_ramp = c.i;
  const std::string ramp = read_number(c);
  double seconds = -1;
  const auto [q, ec2] = std::from_chars(ramp.data(), ramp.data() + ramp.size(), seconds);
  if (ramp.empty() || ec2 != std::errc() || q != ramp.data() + ramp.size() ||
      !std::isfinite(seconds))
    fail(at_ramp, "ramp time must be a number of seconds, got '" + ramp + "'");
  if (seconds < 0) fail(at_ramp, "ramp time " + ramp + " is negative");
  c.skip_space();
  if (c.peek() != ')')
    fail(c.i, "expected ')' to close the tag opened at character " + std::to_string(open));
  end = c.i + 1;
  TextPiece t;
  t.kind = TextPiece::Kind::kTag;
  t.offset = open;
  t.length = end - open;
  t.name = lower(name);
  t.intensity = value;
  t.ramp = seconds;
  return t;
}

// Is the mark at i part of a word or number rather than a pause? ("3.5", "10:30", "1,000", "Dr.")
bool inside_token(const std::u32string& s, std::size_t i) {
  const char32_t c = fold_width(s[i]);
  const char32_t prev = i > 0 ? fold_width(s[i - 1]) : 0;
  const char32_t next = i + 1 < s.size() ? fold_width(s[i + 1]) : 0;
  if ((c == '.' || c == ',' || c == ':') && detail::is_ascii_digit(prev) &&
      detail::is_ascii_digit(next))
    return true;
  if (c == '.' && s[i] == '.') {
    if (detail::is_ascii_alpha(prev) && detail::is_ascii_alpha(next)) return true;  // U.S
    // abbreviation: the word before the dot + "." is in the config list
    std::size_t b = i;
    while (b > 0 && (detail::is_ascii_alpha(s[b - 1]) || s[b - 1] == '.')) --b;
    const std::string word = to_utf8(std::u32string_view(s).substr(b, i + 1 - b));
    const auto& abbr = detail::tables().abbreviations;
    return std::find(abbr.begin(), abbr.end(), word) != abbr.end();
  }
  return false;
}

}  // namespace

std::vector<TextPiece> parse_text(std::string_view text) {
  const std::u32string s = to_u32(text);
  const auto& pauses = detail::tables().pauses;
  std::vector<TextPiece> out;
  const auto text_piece = [&]() -> TextPiece& {
    if (out.empty() || out.back().kind != TextPiece::Kind::kText) {
      TextPiece t;
      t.offset = 0;
      out.push_back(t);
    }
    return out.back();
  };
  for (std::size_t i = 0; i < s.size();) {
    const char32_t c = s[i];
    const char32_t f = fold_width(c);
    if (f == '(' && looks_like_tag(s, i)) {
      std::size_t end = i;
      out.push_back(parse_tag(s, i, end));
      i = end;
      continue;
    }
    // Pause marks: longest match of 1-2 characters in the table; newline.
    std::size_t len = 0;
    double pause = 0;
    if (c == '\n') {
      len = 1;
      pause = detail::tables().newline_pause;
    } else if (!inside_token(s, i)) {
      for (std::size_t l = 2; l >= 1 && !len; --l) {
        if (i + l > s.size()) continue;
        const auto it = pauses.find(to_utf8(std::u32string_view(s).substr(i, l)));
        if (it != pauses.end()) {
          len = l;
          pause = it->second;
        }
      }
    }
    if (len) {
      // Runs of marks ("?!", "。。") count once, with the longest pause.
      if (!out.empty() && out.back().kind == TextPiece::Kind::kPause &&
          out.back().offset + out.back().length == i) {
        out.back().pause = std::max(out.back().pause, pause);
        out.back().text += to_utf8(std::u32string_view(s).substr(i, len));
        out.back().length += len;
      } else {
        TextPiece p;
        p.kind = TextPiece::Kind::kPause;
        p.offset = i;
        p.length = len;
        p.pause = pause;
        p.text = to_utf8(std::u32string_view(s).substr(i, len));
        out.push_back(p);
      }
      i += len;
      continue;
    }
    TextPiece& t = text_piece();
    if (t.text.empty()) t.offset = i;
    append_utf8(t.text, c);
    t.length = i + 1 - t.offset;
    ++i;
  }
  return out;
}

}  // namespace facecast::viseme
