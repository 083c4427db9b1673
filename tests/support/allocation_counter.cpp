#include "support/allocation_counter.h"

#include <atomic>
#include <cstdlib>
#include <new>

extern "C" void* __real_malloc(std::size_t size);

// Under ThreadSanitizer the sanitizer owns operator new/delete: clang links its static
// runtime (libclang_rt.tsan_cxx, --whole-archive) whose strong definitions would clash with
// the replacements below ("multiple definition of operator new"). There the count comes from
// the sanitizer's allocation hook instead, which sees every allocation its allocator makes
// (operator new, malloc, from any library), so the check is at least as strict.
#if defined(__SANITIZE_THREAD__)
#define FFD_TEST_TSAN 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define FFD_TEST_TSAN 1
#endif
#endif

#ifdef FFD_TEST_TSAN
// sanitizer/allocator_interface.h (not shipped with GCC 12; libtsan exports the function).
extern "C" int __sanitizer_install_malloc_and_free_hooks(void (*malloc_hook)(const volatile void*, std::size_t),
                                                         void (*free_hook)(const volatile void*));
#endif

namespace {
thread_local bool t_counting = false;
std::atomic<std::uint64_t> g_allocations{0};

void note() {
  if (t_counting) g_allocations.fetch_add(1, std::memory_order_relaxed);
}

#ifdef FFD_TEST_TSAN
void malloc_hook(const volatile void*, std::size_t) { note(); }
void free_hook(const volatile void*) {}
[[maybe_unused]] const int g_hooks_installed = __sanitizer_install_malloc_and_free_hooks(malloc_hook, free_hook);
#else
void* allocate(std::size_t size) {
  note();
  void* p = __real_malloc(size ? size : 1);
  if (!p) throw std::bad_alloc();
  return p;
}

void* allocate_aligned(std::size_t size, std::align_val_t alignment) {
  note();
  const std::size_t a = static_cast<std::size_t>(alignment);
  void* p = std::aligned_alloc(a, (size + a - 1) / a * a);
  if (!p) throw std::bad_alloc();
  return p;
}
#endif
}  // namespace

namespace ffd::test {
void count_allocations_on_this_thread(bool on) { t_counting = on; }
std::uint64_t allocations() { return g_allocations.load(); }
void reset_allocations() { g_allocations.store(0); }
}  // namespace ffd::test

// -Wl,--wrap=malloc sends malloc calls here; __real_malloc is the C library's malloc, or the
// sanitizer's interceptor when one is linked.
extern "C" void* __wrap_malloc(std::size_t size) {
#ifndef FFD_TEST_TSAN
  note();  // under TSan the malloc hook counts it
#endif
  return __real_malloc(size);
}

#ifndef FFD_TEST_TSAN

void* operator new(std::size_t size) { return allocate(size); }
void* operator new[](std::size_t size) { return allocate(size); }
void* operator new(std::size_t size, std::align_val_t a) { return allocate_aligned(size, a); }
void* operator new[](std::size_t size, std::align_val_t a) { return allocate_aligned(size, a); }
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  note();
  return __real_malloc(size ? size : 1);
}
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept {
  note();
  return __real_malloc(size ? size : 1);
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
#endif
