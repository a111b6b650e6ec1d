// The text front-end: tags, pauses, language runs, Chinese reading, English phonemes.
#include "plan.hpp"

#include <algorithm>

#include "chars.hpp"
#include "en_lexicon.hpp"
#include "espeak.hpp"
#include "facecast/core/error.hpp"
#include "facecast/viseme/pinyin.hpp"
#include "facecast/viseme/text.hpp"
#include "lexicon.hpp"
#include "numbers_zh.hpp"
#include "pinyin_detail.hpp"
#include "tones_zh.hpp"

namespace facecast::viseme::detail {
namespace {

// A token of a text run, in source characters [begin, end).
struct Token {
  enum class Kind { kHan, kLatin, kNumber };
  Kind kind = Kind::kHan;
  std::u32string chars;  // as written
  std::string ascii;     // kLatin / kNumber: width-folded ASCII
  std::size_t begin = 0, end = 0;
  Lang lang = Lang::kZh;
};

bool contains_han(std::string_view text) {
  for (std::size_t pos = 0; pos < text.size();)
    if (is_han(next_code_point(text, pos))) return true;
  return false;
}

bool is_currency(char32_t c) {
  return c == '$' || c == U'¥' || c == U'￥' || c == U'€' || c == U'£';
}

// Splits a text piece into Han runs, Latin words and number expressions; everything else
// (spaces, symbols, emoji) separates tokens and is not spoken.
std::vector<Token> tokenize(const std::u32string& s, std::size_t offset) {
  std::vector<Token> out;
  const auto at = [&](std::size_t i) -> char32_t { return i < s.size() ? fold_width(s[i]) : 0; };
  for (std::size_t i = 0; i < s.size();) {
    const char32_t c = at(i);
    Token t;
    t.begin = offset + i;
    std::size_t j = i;
    if (is_han(s[i])) {
      t.kind = Token::Kind::kHan;
      while (j < s.size() && is_han(s[j])) ++j;
    } else if (is_ascii_alpha(c)) {
      t.kind = Token::Kind::kLatin;
      while (j < s.size()) {
        const char32_t d = at(j);
        const bool joiner =
            (d == '\'' || d == U'’' || d == '-' || d == '.') && is_ascii_alpha(at(j + 1));
        if (is_ascii_alpha(d) || is_ascii_digit(d) || joiner || (d == '.' && j > i))
          ++j;
        else
          break;
      }
    } else if (is_ascii_digit(c) || (is_currency(s[i]) && is_ascii_digit(at(i + 1))) ||
               ((c == '-' || c == '+') && is_ascii_digit(at(i + 1)) &&
                !(i > 0 && (is_ascii_digit(at(i - 1)) || is_ascii_alpha(at(i - 1)))))) {
      t.kind = Token::Kind::kNumber;
      j = i + 1;
      while (j < s.size()) {
        const char32_t d = at(j);
        if (is_ascii_digit(d)) {
          ++j;
        } else if ((d == '.' || d == ',' || d == ':' || d == '/' || d == '-' || d == '~') &&
                   is_ascii_digit(at(j + 1))) {
          ++j;
        } else if (d == '%' || d == U'‰') {
          ++j;
          break;
        } else {
          break;
        }
      }
    } else {
      ++i;
      continue;
    }
    t.chars = s.substr(i, j - i);
    t.end = offset + j;
    if (t.kind != Token::Kind::kHan) {
      for (char32_t ch : t.chars) {
        const char32_t f = fold_width(ch);
        append_utf8(t.ascii, f == '~' ? U'-' : f);
      }
    }
    out.push_back(std::move(t));
    i = j;
  }
  return out;
}

// Numbers take the language of the script they touch; Han and Latin are fixed by their script.
void assign_languages(std::vector<Token>& tokens, LangMode mode, bool text_has_han) {
  for (std::size_t i = 0; i < tokens.size(); ++i) {
    Token& t = tokens[i];
    if (t.kind == Token::Kind::kHan) {
      t.lang = Lang::kZh;
      continue;
    }
    if (t.kind == Token::Kind::kLatin) {
      t.lang = Lang::kEn;
      continue;
    }
    if (mode != LangMode::kAuto) {
      t.lang = mode == LangMode::kZh ? Lang::kZh : Lang::kEn;
      continue;
    }
    const Token* prev = i > 0 && tokens[i - 1].end == t.begin ? &tokens[i - 1] : nullptr;
    const Token* next =
        i + 1 < tokens.size() && tokens[i + 1].begin == t.end ? &tokens[i + 1] : nullptr;
    const auto is = [](const Token* k, Token::Kind kind) { return k && k->kind == kind; };
    if (is(next, Token::Kind::kHan) || is(prev, Token::Kind::kHan))
      t.lang = Lang::kZh;
    else if (is(next, Token::Kind::kLatin) || is(prev, Token::Kind::kLatin))
      t.lang = Lang::kEn;
    else
      t.lang = text_has_han ? Lang::kZh : Lang::kEn;
  }
}

// A Han character of a Chinese run with the source characters it stands for.
struct ZhChar {
  char32_t c;
  std::size_t begin, end;
};

// Polyphone rules (polyphones_zh.json) for a one-character word at run[i]; inside a longer word
// (`in_word`) only the rules marked in_words, and only to choose the tone of the word's spelling.
std::string apply_rules(const std::vector<ZhChar>& run, std::size_t i, std::string reading,
                        const Lexicon& lex, bool in_word) {
  const auto it = tables().polyphones.find(run[i].c);
  if (it == tables().polyphones.end()) return reading;
  const auto has = [](const std::u32string& set, char32_t c) {
    return set.find(c) != std::u32string::npos;
  };
  for (const auto& r : it->second) {
    if (!r.prev.empty() && !(i > 0 && has(r.prev, run[i - 1].c))) continue;
    if (!r.next.empty() && !(i + 1 < run.size() && has(r.next, run[i + 1].c))) continue;
    if (r.prev_repeated && !(i >= 2 && run[i - 1].c == run[i - 2].c)) continue;
    if (r.at_end && i + 1 != run.size()) continue;
    if (in_word && !(r.in_words && toneless(r.reading) == reading && r.reading != reading))
      continue;
    if (lex.has_reading(run[i].c, toneless(r.reading))) return r.reading;
  }
  return reading;
}

class Builder {
 public:
  Builder(Plan& plan, const Options& options) : plan_(plan), options_(options) {}

  void add_text(const TextPiece& piece, bool text_has_han) {
    std::vector<Token> tokens = tokenize(to_u32(piece.text), piece.offset);
    assign_languages(tokens, options_.lang, text_has_han);
    std::vector<ZhChar> run;
    for (std::size_t i = 0; i < tokens.size(); ++i) {
      const Token& t = tokens[i];
      if (t.lang == Lang::kEn) {
        flush_chinese(run);
        add_english(t);
      } else if (t.kind == Token::Kind::kHan) {
        for (std::size_t k = 0; k < t.chars.size(); ++k)
          run.push_back({t.chars[k], t.begin + k, t.begin + k + 1});
      } else {
        const std::u32string next = i + 1 < tokens.size() && tokens[i + 1].kind == Token::Kind::kHan
                                        ? tokens[i + 1].chars.substr(0, 4)
                                        : std::u32string();
        const char32_t prev = run.empty() ? 0 : run.back().c;
        for (char32_t c : read_number_zh(t.ascii, next, prev)) run.push_back({c, t.begin, t.end});
      }
    }
    flush_chinese(run);
  }

  void add_pause(double seconds) {
    if (!plan_.items.empty() && plan_.items.back().kind == PlanItem::Kind::kPause) {
      plan_.items.back().pause = std::max(plan_.items.back().pause, seconds);
      return;
    }
    PlanItem p;
    p.kind = PlanItem::Kind::kPause;
    p.pause = seconds;
    plan_.items.push_back(p);
  }

  void add_tag(const TextPiece& piece) {
    PlanItem t;
    t.kind = PlanItem::Kind::kTag;
    t.name = piece.name;
    t.intensity = piece.intensity;
    t.ramp = piece.ramp;
    plan_.items.push_back(t);
  }

 private:
  void add_unit(PlanUnit u) {
    PlanItem item;
    item.kind = PlanItem::Kind::kUnit;
    item.unit = plan_.units.size();
    plan_.items.push_back(item);
    plan_.units.push_back(std::move(u));
  }

  void add_english(const Token& t) {
    PlanUnit u;
    u.lang = Lang::kEn;
    u.text = to_utf8(t.chars);
    u.src_begin = t.begin;
    u.src_end = t.end;
    u.word = plan_.words.size();
    std::vector<std::string> phones = espeak::phonemize(t.ascii, options_.en_voice);
    if (english_lexicon_applies(options_))
      if (auto listed = lexicon_phones(EnglishLexicon::get(), t.ascii, phones)) {
        phones = std::move(*listed);
        u.spoken = espeak_phoneme_input(phones);
      }
    u.phones = english_phones(phones, options_, u.spoken.empty());
    plan_.words.push_back({u.text, plan_.units.size(), plan_.units.size() + 1});
    add_unit(std::move(u));
  }

  void flush_chinese(std::vector<ZhChar>& run) {
    if (run.empty()) return;
    const Lexicon& lex = Lexicon::get();
    std::u32string chars;
    for (const auto& z : run) chars += z.c;
    const auto segments = lex.segment(chars);
    // Readings in word context (docs/algorithms.md#chinese-reading, #chinese-tones).
    std::vector<ZhSyllable> syllables(run.size());
    for (std::size_t w = 0; w < segments.size(); ++w) {
      const auto& seg = segments[w];
      const bool single = seg.end - seg.begin == 1;
      for (std::size_t k = seg.begin; k < seg.end; ++k) {
        std::string bare = seg.toneless[k - seg.begin];
        bare = apply_rules(run, k, bare, lex, !single);
        const bool toned = !bare.empty() && bare.back() >= '1' && bare.back() <= '5';
        const bool plain = bare.empty() || toned;
        syllables[k] = {run[k].c, plain ? bare : lex.tone(run[k].c, bare, single || k > seg.begin),
                        w};
        if (!is_pinyin(syllables[k].pinyin)) syllables[k].pinyin.clear();
      }
    }
    word_tones(syllables);
    const std::vector<std::string> spoken = spoken_tones(syllables);
    for (const auto& seg : segments) {
      PlanWord word;
      word.text = to_utf8(std::u32string_view(chars).substr(seg.begin, seg.end - seg.begin));
      word.first = plan_.units.size();
      for (std::size_t k = seg.begin; k < seg.end; ++k) {
        if (syllables[k].pinyin.empty()) continue;  // a character nobody knows how to read
        PlanUnit u;
        u.lang = Lang::kZh;
        u.text = to_utf8(run[k].c);
        u.pinyin = syllables[k].pinyin;
        u.spoken = spoken[k];
        u.src_begin = run[k].begin;
        u.src_end = run[k].end;
        u.word = plan_.words.size();
        add_unit(std::move(u));
      }
      word.last = plan_.units.size();
      if (word.last > word.first) plan_.words.push_back(std::move(word));
    }
    plan_.has_zh = true;
    run.clear();
  }

  Plan& plan_;
  const Options& options_;
};

// Chinese syllable durations need to know which syllables end a phrase.
void time_chinese_units(Plan& plan, const Options& options) {
  for (std::size_t i = 0; i < plan.items.size(); ++i) {
    if (plan.items[i].kind != PlanItem::Kind::kUnit) continue;
    PlanUnit& u = plan.units[plan.items[i].unit];
    if (u.lang != Lang::kZh) continue;
    std::size_t j = i + 1;
    while (j < plan.items.size() && plan.items[j].kind == PlanItem::Kind::kTag) ++j;
    const bool final = j == plan.items.size() || plan.items[j].kind == PlanItem::Kind::kPause;
    u.phones = chinese_phones(u.pinyin, chinese_syllable_seconds(u.pinyin, final, options));
  }
}

}  // namespace

double PlanUnit::seconds() const {
  double s = 0;
  for (const auto& p : phones) s += p.seconds;
  return s;
}

namespace {

// The first context rule of phones_espeak_en.json that matches phone i of `phones` (name, stress).
const PhoneMap* context_map(const std::vector<std::pair<std::string, char>>& phones,
                            std::size_t i) {
  const auto is = [](const std::vector<std::string>& set, const std::string& name) {
    return set.empty() || std::find(set.begin(), set.end(), name) != set.end();
  };
  const std::string prev = i > 0 ? phones[i - 1].first : "#";
  const std::string next = i + 1 < phones.size() ? phones[i + 1].first : "#";
  for (const auto& r : tables().espeak_en_context)
    if (r.phone == phones[i].first && (!r.stress || r.stress == phones[i].second) &&
        is(r.prev, prev) && is(r.next, next))
      return &r.as;
  return nullptr;
}

}  // namespace

std::vector<PlanPhone> english_phones(const std::vector<std::string>& espeak_phones,
                                      const Options& options, bool context_rules) {
  const auto& t = tables();
  const double scale = t.en_reference_rate / options.rate;
  std::vector<std::pair<std::string, char>> known;  // name without stress marks, stress
  for (std::string name : espeak_phones) {
    char stress = '0';
    while (!name.empty() && (name[0] == '\'' || name[0] == ',')) {
      if (stress != '1') stress = name[0] == '\'' ? '1' : '2';
      name.erase(0, 1);
    }
    if (t.espeak_en.count(name)) known.emplace_back(std::move(name), stress);
  }
  std::vector<PlanPhone> out;
  for (std::size_t i = 0; i < known.size(); ++i) {
    const PhoneMap& m = t.espeak_en.at(known[i].first);
    double seconds = t.en_class_seconds.at(m.duration_class) * scale;
    if (known[i].second == '1') seconds *= t.en_stress_factor;
    PhoneMap visemes = m;
    if (const PhoneMap* c = context_rules ? context_map(known, i) : nullptr) {
      visemes.oculus = c->oculus;
      visemes.zh15 = c->zh15;
    }
    out.push_back({known[i].first, seconds, std::move(visemes)});
  }
  return out;
}

double chinese_syllable_seconds(const std::string& pinyin, bool phrase_final, const Options& o) {
  double s = 1.0 / o.rate;
  if (!pinyin.empty() && pinyin.back() == '5') s *= o.neutral_tone_factor;
  if (phrase_final) s *= o.phrase_final_lengthening;
  return s;
}

std::vector<PlanPhone> chinese_phones(const std::string& pinyin, double syllable_seconds) {
  const PinyinParts parts = split_pinyin(pinyin);
  const auto names = parts.phones();
  const auto maps = zh_phone_maps(parts);
  const auto weights = zh_phone_weights(parts);
  double total = 0;
  for (double w : weights) total += w;
  std::vector<PlanPhone> out;
  for (std::size_t i = 0; i < names.size(); ++i)
    out.push_back({names[i], syllable_seconds * weights[i] / total, maps[i]});
  return out;
}

Plan make_plan(std::string_view text, const Options& options) {
  if (!(options.rate > 0.1 && options.rate < 100))
    throw Error("rate must be between 0.1 and 100 syllables per second");
  const std::vector<TextPiece> pieces = parse_text(text);
  const bool has_han = std::any_of(pieces.begin(), pieces.end(), [](const TextPiece& p) {
    return p.kind == TextPiece::Kind::kText && contains_han(p.text);
  });
  Plan plan;
  Builder b(plan, options);
  for (const auto& piece : pieces) {
    switch (piece.kind) {
      case TextPiece::Kind::kText:
        b.add_text(piece, has_han);
        break;
      case TextPiece::Kind::kPause:
        b.add_pause(piece.pause);
        break;
      case TextPiece::Kind::kTag:
        b.add_tag(piece);
        break;
    }
  }
  time_chinese_units(plan, options);
  return plan;
}

}  // namespace facecast::viseme::detail

namespace facecast::viseme {

std::vector<std::string> to_pinyin(std::string_view text) {
  Options o;
  o.lang = LangMode::kZh;
  std::vector<std::string> out;
  const auto plan = detail::make_plan(text, o);
  for (const auto& u : plan.units)
    if (u.lang == detail::Lang::kZh) out.push_back(u.pinyin);
  return out;
}

}  // namespace facecast::viseme
