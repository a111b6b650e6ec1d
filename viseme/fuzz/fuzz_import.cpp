// libFuzzer target: every timestamp importer on the same bytes (the first byte picks none: all
// six run), so malformed JSON, NDJSON, TextGrid and TSV are all exercised.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "facecast/core/error.hpp"
#include "facecast/viseme/import.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace v = facecast::viseme;
  const std::string_view content(reinterpret_cast<const char*>(data), size);
  for (auto format :
       {v::TimestampFormat::kJson, v::TimestampFormat::kAzure, v::TimestampFormat::kPolly,
        v::TimestampFormat::kMfa, v::TimestampFormat::kRhubarb, v::TimestampFormat::kElevenLabs}) {
    try {
      (void)v::import_timestamps(format, content, {}, v::PhoneSet::kAuto, "fuzz");
    } catch (const facecast::Error&) {
    }
  }
  return 0;
}
