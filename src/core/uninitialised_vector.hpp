#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <type_traits>
#include <utility>
#include <vector>

namespace mac_registration {

// An allocator whose resize() leaves new elements of trivial types uninitialised. The per-edge sums of a
// dense graph and its bit rows are written in full on the registration's threads: a value-initialising
// resize would first zero megabytes on one thread, taking every page fault of the fresh memory there.
template <typename T>
class DefaultInitAllocator : public std::allocator<T> {
 public:
  using value_type = T;
  template <typename U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };

  DefaultInitAllocator() noexcept = default;
  template <typename U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}

  template <typename U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible<U>::value) {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

// A std::vector whose resize(n) does not zero: every element must be written before it is read.
// Construction with a value, assign() and push_back() initialise as usual.
template <typename T>
using UninitialisedVector = std::vector<T, DefaultInitAllocator<T>>;

// The first element of `data` on a 64-byte cache line, for buffers allocated with up to
// kCacheLineBytes / sizeof(T) - 1 elements to spare (malloc aligns to 16 bytes only). A SIMD load across
// two lines costs two.
constexpr std::size_t kCacheLineBytes = 64;
template <typename T>
T* firstOnCacheLine(T* data) {
  static_assert(kCacheLineBytes % sizeof(T) == 0, "whole elements to a line");
  const auto address = reinterpret_cast<std::uintptr_t>(data);
  const std::size_t line = kCacheLineBytes / sizeof(T);
  return data + (line - (address / sizeof(T)) % line) % line;
}

}  // namespace mac_registration
