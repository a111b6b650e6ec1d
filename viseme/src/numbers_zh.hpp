#pragma once
// Numbers in Chinese text read the way a speaker says them, as Han characters.
#include <string>
#include <string_view>

namespace facecast::viseme::detail {

/// `token` is a number expression in ASCII (full-width folded): "2024", "3.5%", "10:30",
/// "¥12.50", "2024-03-05", "1/3", "1,000", "-5", "3-5". `next` is the Han text right after it (for
/// 年 after a year, measure words that make 2 read 两) and `prev` the Han character right before
/// (第 makes an ordinal). Returns the Han reading, e.g. "二零二四", "百分之三点五", "十点三十分".
std::u32string read_number_zh(std::string_view token, std::u32string_view next, char32_t prev);

/// Cardinal reading of a non-negative integer given as decimal digits: "10005" -> "一万零五".
/// `head_liang`: read a leading 2 before 千/万/亿 (and 百, per config) as 两.
std::u32string read_cardinal_zh(std::string_view digits, bool head_liang);

}  // namespace facecast::viseme::detail
