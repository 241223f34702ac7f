#pragma once
// A std::vector whose resize leaves new elements of a trivial type uninitialised, for the large
// buffers that threads then fill in parallel: their first writes fault the pages in on every
// core, where a zero fill would fault them all in on one (a page's first touch costs 8-14 µs on
// the virtual machines this project is measured on, so a 41 MB factor's zero fill alone took
// tens of milliseconds).
#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

namespace hdeform::detail {

template <class T, class Base = std::allocator<T>>
class DefaultInitAllocator : public Base {
  using Traits = std::allocator_traits<Base>;

 public:
  template <class U>
  struct rebind {
    using other = DefaultInitAllocator<U, typename Traits::template rebind_alloc<U>>;
  };
  using Base::Base;

  template <class U>
  void construct(U* at) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(at)) U;
  }
  template <class U, class... Args>
  void construct(U* at, Args&&... args) {
    Traits::construct(static_cast<Base&>(*this), at, std::forward<Args>(args)...);
  }
};

template <class T>
using UninitializedVector = std::vector<T, DefaultInitAllocator<T>>;

}  // namespace hdeform::detail
