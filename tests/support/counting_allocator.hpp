#pragma once
// Counts heap allocations in the test program that includes this header (exactly one translation
// unit per test program may include it): replaces the global operator new/delete.
#include <atomic>
#include <cstdlib>
#include <new>

namespace alphainv::test {
inline std::atomic<long> g_allocations{0};
/// Allocations made so far.
inline long allocation_count() { return g_allocations.load(); }
}  // namespace alphainv::test

// GCC cannot see that operator new below is malloc-based and warns on the matching free().
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#endif

void* operator new(std::size_t size) {
  alphainv::test::g_allocations.fetch_add(1);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) { return operator new(size); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
