#include "numbers_zh.hpp"

#include <algorithm>
#include <vector>

#include "chars.hpp"
#include "tables.hpp"

namespace facecast::viseme::detail {
namespace {

std::u32string u32(const std::string& s) {
  return to_u32(s);
}

std::u32string digit(char c) {
  return u32(tables().numbers.digits[static_cast<std::size_t>(c - '0')]);
}

bool all_digits(std::string_view s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

std::u32string read_digits(std::string_view s) {
  std::u32string out;
  for (char c : s) out += digit(c);
  return out;
}

std::string strip_leading_zeros(std::string_view s) {
  const auto p = s.find_first_not_of('0');
  return p == std::string_view::npos ? "0" : std::string(s.substr(p));
}

// 0..9999 with 千百十; `head` = first section of the number (一十 -> 十, leading 两).
std::u32string read_section(int v, bool head, bool liang) {
  static const char32_t kUnits[] = {U'千', U'百', U'十', 0};
  const bool bai_liang = tables().numbers.liang_before_bai;
  std::u32string out;
  bool started = false, zero = false;
  for (int k = 0; k < 4; ++k) {
    static const int kPow[] = {1000, 100, 10, 1};
    const int d = (v / kPow[k]) % 10;
    if (d == 0) {
      zero = started;
      continue;
    }
    if (zero) out += U'零';
    zero = false;
    const bool first = !started && head;
    if (first && k == 2 && d == 1) {
      out += U'十';  // 10-19: 十二, not 一十二
    } else if (first && liang && d == 2 && (k == 0 || (k == 1 && bai_liang))) {
      out += U'两';
      out += kUnits[k];
    } else {
      out += digit(static_cast<char>('0' + d));
      if (kUnits[k]) out += kUnits[k];
    }
    started = true;
  }
  return out;
}

// Splits "12.50" into int and fraction parts.
std::u32string read_decimal(std::string_view s, bool liang) {
  const auto dot = s.find('.');
  std::u32string out = read_cardinal_zh(s.substr(0, dot), liang);
  if (dot != std::string_view::npos && dot + 1 < s.size()) {
    out += u32(tables().numbers.point);
    out += read_digits(s.substr(dot + 1));
  }
  return out;
}

bool starts_with_any(std::u32string_view text, const std::vector<std::string>& words) {
  for (const auto& w : words) {
    const std::u32string u = to_u32(w);
    if (text.substr(0, u.size()) == u) return true;
  }
  return false;
}

std::vector<std::string_view> split_on(std::string_view s, char sep) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= s.size(); ++i)
    if (i == s.size() || s[i] == sep) {
      out.push_back(s.substr(start, i - start));
      start = i + 1;
    }
  return out;
}

bool is_decimal(std::string_view s) {
  const auto dot = s.find('.');
  if (dot == std::string_view::npos) return all_digits(s);
  return all_digits(s.substr(0, dot)) && all_digits(s.substr(dot + 1));
}

}  // namespace

std::u32string read_cardinal_zh(std::string_view digits_in, bool head_liang) {
  const std::string digits = strip_leading_zeros(digits_in);
  if (digits == "0") return digit('0');
  if (digits.size() > 16) return read_digits(digits);
  static const char32_t kBig[] = {0, U'万', U'亿', U'万'};  // 万亿 for 10^12
  std::vector<int> sections;                                // least significant first
  for (std::size_t end = digits.size(); end > 0;) {
    const std::size_t begin = end >= 4 ? end - 4 : 0;
    sections.push_back(std::stoi(digits.substr(begin, end - begin)));
    end = begin;
  }
  std::u32string out;
  bool started = false, zero = false;
  for (std::size_t i = sections.size(); i-- > 0;) {
    const int v = sections[i];
    if (v == 0) {
      zero = started;
      continue;
    }
    if (started && (zero || v < 1000)) out += U'零';
    zero = false;
    const bool head = !started;
    if (head && head_liang && v == 2 && i > 0) {
      out += U'两';
    } else {
      out += read_section(v, head, head_liang);
    }
    if (i > 0) {
      if (i == 3) {
        out += U'万';
        out += U'亿';
      } else {
        out += kBig[i];
      }
    }
    started = true;
  }
  return out;
}

std::u32string read_number_zh(std::string_view token_in, std::u32string_view next, char32_t prev) {
  const auto& num = tables().numbers;
  std::string token(token_in);
  token.erase(std::remove(token.begin(), token.end(), ','), token.end());  // 1,000
  std::u32string prefix, suffix;
  for (const auto& [sym, name] : num.currency_prefix) {
    if (token.compare(0, sym.size(), sym) == 0) {
      token.erase(0, sym.size());
      suffix = u32(name);
      break;
    }
  }
  if (!token.empty() && token.back() == '%') {
    token.pop_back();
    prefix = u32(num.percent_prefix);
  }
  if (!token.empty() && (token[0] == '-' || token[0] == '+') && token.size() > 1) {
    if (token[0] == '-') prefix += u32(num.negative);
    token.erase(0, 1);
  }
  const bool ordinal = prev == U'第';
  const bool measure = !ordinal && starts_with_any(next, num.measure_words);

  std::u32string body;
  const auto colon = split_on(token, ':');
  const auto dash = split_on(token, token.find('/') != std::string::npos ? '/' : '-');
  const auto dots = split_on(token, '.');
  if (colon.size() >= 2 && colon.size() <= 3 &&
      std::all_of(colon.begin(), colon.end(), [](auto p) { return all_digits(p); })) {
    body = read_cardinal_zh(colon[0], true) + u32(num.hour);  // 10:30 -> 十点三十分
    const std::string mm = strip_leading_zeros(colon[1]);
    if (mm != "0") {
      if (colon[1].size() == 2 && colon[1][0] == '0') body += digit('0');
      body += read_cardinal_zh(mm, false) + u32(num.minute);
    }
    if (colon.size() == 3 && strip_leading_zeros(colon[2]) != "0")
      body += read_cardinal_zh(colon[2], false) + u32(num.second);
  } else if ((dash.size() == 3 || (dots.size() == 3 && dots[0].size() == 4)) &&
             (dash.size() == 3 ? dash : dots)[0].size() == 4 &&
             std::all_of((dash.size() == 3 ? dash : dots).begin(),
                         (dash.size() == 3 ? dash : dots).end(),
                         [](auto p) { return all_digits(p); })) {
    const auto& d = dash.size() == 3 ? dash : dots;  // 2024-03-05 -> 二零二四年三月五日
    body = read_digits(d[0]) + u32(num.year) + read_cardinal_zh(d[1], false) + u32(num.month) +
           read_cardinal_zh(d[2], false) + u32(num.day);
  } else if (dash.size() == 2 && token.find('/') != std::string::npos && all_digits(dash[0]) &&
             all_digits(dash[1])) {
    body = read_cardinal_zh(dash[1], false) + u32(num.fraction) + read_cardinal_zh(dash[0], false);
  } else if (dash.size() == 2 && is_decimal(dash[0]) && is_decimal(dash[1]) && !dash[0].empty() &&
             !dash[1].empty()) {
    body = read_decimal(dash[0], measure) + u32(num.range) + read_decimal(dash[1], measure);
  } else if (all_digits(token) && token.size() == 4 && !next.empty() && next[0] == U'年') {
    body = read_digits(token);  // 2024年
  } else if (all_digits(token) && token.size() > 1 &&
             (token[0] == '0' || token.size() >= num.digit_string_min_length)) {
    body = read_digits(token);  // codes, phone numbers
  } else if (is_decimal(token) && !token.empty() && token != ".") {
    if (token == "2" && measure && prefix.empty())
      body = U"两";
    else
      body = read_decimal(token, true);
  } else {
    // Not a number we know: read every digit, drop the rest.
    for (char c : token)
      if (c >= '0' && c <= '9') body += digit(c);
  }
  return prefix + body + suffix;
}

}  // namespace facecast::viseme::detail
