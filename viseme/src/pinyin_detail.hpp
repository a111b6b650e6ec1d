#pragma once
// Per-phone viseme maps of a Mandarin syllable (the rule of pinyin.json applied phone by phone).
#include <vector>

#include "facecast/viseme/pinyin.hpp"
#include "tables.hpp"

namespace facecast::viseme::detail {

/// One PhoneMap per phone of `parts` (same order as parts.phones()); 'y' before u-umlaut rounds.
std::vector<PhoneMap> zh_phone_maps(const PinyinParts& parts);

/// Relative duration weights of the phones of `parts` (pinyin.json "durations").
std::vector<double> zh_phone_weights(const PinyinParts& parts);

/// "hao3" -> "hao": the toneless syllable.
std::string toneless(std::string_view numbered);

}  // namespace facecast::viseme::detail
