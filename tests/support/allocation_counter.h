#pragma once
// Counts heap allocations made by threads that opt in: every operator new, and every malloc
// from code linked into the test program (the moodycamel queues allocate with malloc). The
// test executable links with -Wl,--wrap=malloc so that __wrap_malloc sees those calls.
// Under ThreadSanitizer the sanitizer's allocation hook counts instead (see the .cpp).
#include <cstdint>

namespace ffd::test {

// While counting is on for the calling thread, its allocations are added to allocations().
void count_allocations_on_this_thread(bool on);
std::uint64_t allocations();
void reset_allocations();

}  // namespace ffd::test
