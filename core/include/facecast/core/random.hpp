#pragma once
// Identifiers that must not collide or be guessed (upload, rig and job ids, temporary names): each
// draws fresh bytes from the kernel (getrandom(2)), so threads share no generator state and two
// processes, or two instances sharing a data folder, never draw the same sequence.
#include <cstddef>
#include <string>

namespace facecast {

/// Fills `out` with `n` bytes from the kernel's random source; throws Error(kInternal) when the
/// kernel cannot give them (never on Linux 3.17+ once the pool is initialized).
void random_bytes(void* out, std::size_t n);

/// `bytes` random bytes as 2 x `bytes` lowercase hex digits.
std::string random_hex(std::size_t bytes);

/// A time-ordered unique id: 12 hex digits of Unix milliseconds, then 8 random hex digits (20 in
/// all, sorting by creation time to the millisecond). Unique within the process (a tail drawn
/// twice in one millisecond is drawn again); across processes and hosts without coordination two
/// ids of the same millisecond share their tail with chance 2^-32.
std::string time_ordered_hex();

}  // namespace facecast
