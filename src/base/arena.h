// Bump allocator over the caller's workspace. Run once with base == nullptr to
// measure (every carve is 64-byte aligned, so the measured total is exact for any
// 64-byte aligned base), then again over the real buffer.
#pragma once
#include <cstddef>
#include <cstdint>

namespace ffseg {

constexpr std::size_t kAlign = 64;

class Arena {
 public:
  Arena() = default;
  Arena(void* base, std::size_t capacity)
      : base_(static_cast<unsigned char*>(base)), capacity_(capacity) {}

  // Carves count objects of T; returns nullptr in measuring mode or when the
  // buffer is exhausted (then ok() turns false). Memory is not initialised.
  template <class T>
  T* alloc(std::size_t count) {
    return static_cast<T*>(alloc_bytes(count, sizeof(T)));
  }

  void* alloc_bytes(std::size_t count, std::size_t elem) {
    if (elem != 0 && count > (SIZE_MAX - kAlign) / elem) { overflow_ = true; return nullptr; }
    std::size_t bytes = round_up(count * elem);
    if (bytes > SIZE_MAX - used_) { overflow_ = true; return nullptr; }
    std::size_t at = used_;
    used_ += bytes;
    if (base_ == nullptr || used_ > capacity_) return nullptr;
    return base_ + at;
  }

  std::size_t used() const { return used_; }
  bool measuring() const { return base_ == nullptr; }
  bool overflowed() const { return overflow_; }
  bool ok() const { return !overflow_ && (base_ == nullptr || used_ <= capacity_); }

  static std::size_t round_up(std::size_t b) { return (b + kAlign - 1) & ~(kAlign - 1); }

 private:
  unsigned char* base_ = nullptr;
  std::size_t capacity_ = 0;
  std::size_t used_ = 0;
  bool overflow_ = false;
};

}  // namespace ffseg
