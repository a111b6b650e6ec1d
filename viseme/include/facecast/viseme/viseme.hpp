#pragma once
// facecast::viseme — text and timestamps to timed visemes and expressions. One include for all.
#include "facecast/core/wav.hpp"
#include "facecast/viseme/align.hpp"
#include "facecast/viseme/analyze.hpp"
#include "facecast/viseme/audio.hpp"
#include "facecast/viseme/import.hpp"
#include "facecast/viseme/lipsync.hpp"
#include "facecast/viseme/options.hpp"
#include "facecast/viseme/pinyin.hpp"
#include "facecast/viseme/text.hpp"
#include "facecast/viseme/utterance.hpp"
