#pragma once
// The decoded-bytes budget of one file (DecodeLimits::budget): every decoder and reader charges
// what it is about to allocate before it allocates it, so a file that declares more than the
// budget is an Error(kLimit) naming the field, never an allocation.
#include <cstddef>
#include <string>
#include <string_view>

#include "facecast/rig/decode_limits.hpp"

namespace facecast::rig::detail {

/// a x b, saturating at the largest size_t (so a declared count cannot wrap a check around).
std::size_t product(std::size_t a, std::size_t b);

class DecodeBudget {
 public:
  /// No limit (documents built in code).
  DecodeBudget() = default;
  /// limits.budget(file_bytes), of which `used` is already spent. `noun` names what the budget is
  /// a multiple of in errors ("file", or "decoded file" for the packed document a view reads).
  DecodeBudget(const DecodeLimits& limits, std::size_t file_bytes, std::size_t used = 0,
               std::string noun = "file");

  /// Bytes read from outside the file (a .gltf's external buffers) raise the budget.
  void add_file_bytes(std::size_t bytes);
  /// Spends `bytes`, or throws Error(kLimit): "<at>: <doing> of N bytes is over the budget of B
  /// (64 x the F-byte file)".
  void charge(std::size_t bytes, const std::string& at, std::string_view doing);

  bool limited() const { return limited_; }
  std::size_t used() const { return used_; }
  std::size_t file_bytes() const { return file_bytes_; }
  const DecodeLimits& limits() const { return limits_; }

 private:
  bool limited_ = false;
  DecodeLimits limits_;
  std::size_t file_bytes_ = 0, total_ = 0, used_ = 0;
  std::string noun_ = "file";
};

}  // namespace facecast::rig::detail
