#pragma once
// Counts heap allocations while g_count_allocations is set, by replacing this test binary's
// global operator new. Include it in exactly one source file of a test binary.

#include <atomic>
#include <cstdlib>
#include <new>

namespace kneesim::test {
inline std::atomic<long> g_allocations{0};
inline std::atomic<bool> g_count_allocations{false};
inline void* countedAlloc(std::size_t n) {
  if (g_count_allocations) ++g_allocations;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
}  // namespace kneesim::test

void* operator new(std::size_t n) { return kneesim::test::countedAlloc(n); }
void* operator new[](std::size_t n) { return kneesim::test::countedAlloc(n); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
