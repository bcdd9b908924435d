#pragma once
// Buffer<T>: a std::vector whose growth leaves new elements default-initialised (for
// numbers and plain structs: not written at all) instead of zeroed, for arrays that the
// threads fill. A fresh page of memory costs a fault when it is first written (about
// 1.5 us per 4 KiB on the machines measured: 0.4 ms per MB, ten times a memset of the
// same memory). A std::vector<T>(n) takes all of its faults on the thread that zeroes it;
// a Buffer<T>(n) filled by parallel_chunks() takes them on the threads that fill it.
// Only for elements that are all written before they are read: resize() leaves the new
// ones unwritten, so a resize() followed by += on them is a bug (size with a value,
// Buffer<T>(n, T{}), for sums).

#include <memory>
#include <type_traits>
#include <new>
#include <utility>
#include <vector>

namespace raybundle {

template <class T>
struct DefaultInitAllocator : std::allocator<T> {
    using std::allocator<T>::allocator;
    template <class U>
    struct rebind {
        using other = DefaultInitAllocator<U>;
    };
    template <class U>
    void construct(U* p) noexcept(std::is_nothrow_default_constructible<U>::value) {
        ::new (static_cast<void*>(p)) U;
    }
    template <class U, class... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
};

template <class T>
using Buffer = std::vector<T, DefaultInitAllocator<T>>;

}  // namespace raybundle
