// One 64-bit key for a pair of integers: a grid cell's (x, y), or a pair of
// ids, for hashed lookups.
#pragma once

namespace oslam {

// The first in the high 32 bits, the second's low 32 bits in the low ones:
// distinct for every pair of values within 32 bits.
inline long long PairKey(long long first, long long second) {
  return static_cast<long long>((static_cast<unsigned long long>(first) << 32) ^
                                (static_cast<unsigned long long>(second) & 0xffffffffULL));
}

}  // namespace oslam
