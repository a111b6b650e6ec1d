#pragma once
// Which sanitizer the tests are compiled under: FACECAST_ASAN (AddressSanitizer) or FACECAST_TSAN
// (ThreadSanitizer). GCC defines __SANITIZE_ADDRESS__ / __SANITIZE_THREAD__; clang 14 answers
// __has_feature instead (the ASan+UBSan tree is built by clang, scripts/test.sh).
#if defined(__SANITIZE_ADDRESS__)
#define FACECAST_ASAN 1
#elif defined(__SANITIZE_THREAD__)
#define FACECAST_TSAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define FACECAST_ASAN 1
#elif __has_feature(thread_sanitizer)
#define FACECAST_TSAN 1
#endif
#endif
