#include "ffd/state.h"

#include <cstdio>
#include <cstring>

namespace ffd {

namespace {
constexpr std::uint64_t kFnvOffset = 0xcbf29ce484222325ull;
constexpr std::uint64_t kFnvPrime = 0x100000001b3ull;

// Word-wise FNV-1a: one multiply per double instead of eight keeps a hash of a whole
// lattice cheap enough for the 1 kHz thread to take every few steps.
void mix(std::uint64_t& hash, double value) {
  std::uint64_t bits;
  std::memcpy(&bits, &value, sizeof bits);
  hash ^= bits;
  hash *= kFnvPrime;
}

void mix(std::uint64_t& hash, const Vec3& v) {
  for (int i = 0; i < 3; ++i) mix(hash, v[i]);
}
}  // namespace

std::string hash_hex(std::uint64_t hash) {
  char digits[17];
  std::snprintf(digits, sizeof digits, "%016llx", static_cast<unsigned long long>(hash));
  return digits;
}

std::uint64_t state_hash(const State& state) {
  std::uint64_t hash = kFnvOffset;
  for (const Vec3& p : state.x) mix(hash, p);
  for (const Vec3& v : state.v) mix(hash, v);
  mix(hash, state.probe.x);
  mix(hash, state.probe.v);
  return hash;
}

}  // namespace ffd
