#pragma once

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

}  // namespace mac_registration
