#include <cstring>

#include "ffd/state.h"

namespace ffd {

namespace {
constexpr std::uint64_t kFnvOffset = 0xcbf29ce484222325ull;
constexpr std::uint64_t kFnvPrime = 0x100000001b3ull;

void fnv1a(std::uint64_t& hash, const void* data, std::size_t bytes) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < bytes; ++i) {
    hash ^= p[i];
    hash *= kFnvPrime;
  }
}
}  // namespace

std::uint64_t state_hash(const State& state) {
  std::uint64_t hash = kFnvOffset;
  // Raw bits, component by component, so the value never depends on padding or layout.
  for (const Vec3& p : state.x) {
    for (int i = 0; i < 3; ++i) {
      const double c = p[i];
      fnv1a(hash, &c, sizeof c);
    }
  }
  for (const Vec3& v : state.v) {
    for (int i = 0; i < 3; ++i) {
      const double c = v[i];
      fnv1a(hash, &c, sizeof c);
    }
  }
  return hash;
}

}  // namespace ffd
