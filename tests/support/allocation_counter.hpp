#pragma once
// Counts heap allocations for tests of allocation-free hot loops. Replaces the global operator
// new and delete of the test binary, so include it in exactly one source file of a binary.

#include <atomic>
#include <cstdlib>
#include <new>

namespace kneesim::test {

/// Allocations counted since the last reset, while g_count_allocations is set.
inline std::atomic<long> g_allocations{0};
/// Whether operator new counts.
inline std::atomic<bool> g_count_allocations{false};

inline void* countedAlloc(std::size_t n) {
  if (g_count_allocations) ++g_allocations;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}

/// Number of allocations @p fn makes.
template <class Fn>
long countAllocations(Fn&& fn) {
  g_allocations = 0;
  g_count_allocations = true;
  fn();
  g_count_allocations = false;
  return g_allocations;
}

}  // namespace kneesim::test

void* operator new(std::size_t n) { return kneesim::test::countedAlloc(n); }
void* operator new[](std::size_t n) { return kneesim::test::countedAlloc(n); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
