// One workspace block reused by every input of a fuzz target. A fresh
// multi-megabyte allocation per input (the intensity-model buffers make even an
// n = 2 engine 1.5 MB) cost more than the engine's own work: page faults and
// ASan's fill of new chunks. Instead the block stays and ASan poisoning marks
// everything outside [p, p + bytes) unaddressable, so a read or write past
// what the engine was given is still reported at once.
#pragma once
#include <sanitizer/asan_interface.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>

namespace ffseg_fuzz {

class ReusedBlock {
 public:
  ReusedBlock() = default;
  ReusedBlock(const ReusedBlock&) = delete;
  ReusedBlock& operator=(const ReusedBlock&) = delete;
  ~ReusedBlock() {
    if (base_) ASAN_UNPOISON_MEMORY_REGION(base_, cap_);
    std::free(base_);
  }

  // Returns p with p % 64 == misalign and [p, p + bytes) addressable; the rest
  // of the block is poisoned. When misalign == 0 and bytes % 64 == 0 (every
  // exact workspace size is a multiple of 64), p + bytes is the block's end,
  // so the first byte past the workspace is poisoned exactly. The contents are
  // whatever the previous input left: the engine must not depend on them.
  unsigned char* get(size_t bytes, size_t misalign) {
    const size_t want = (bytes + misalign + 127) / 64 * 64;
    if (want > cap_) {
      if (base_) ASAN_UNPOISON_MEMORY_REGION(base_, cap_);
      std::free(base_);
      base_ = nullptr;
      cap_ = want > 2 * cap_ ? want : 2 * cap_;
      void* m = nullptr;
      if (posix_memalign(&m, 64, cap_) != 0) std::abort();
      base_ = static_cast<unsigned char*>(m);
    }
    const size_t off = (cap_ - (bytes + misalign)) & ~size_t(63);
    unsigned char* p = base_ + off + misalign;
    ASAN_POISON_MEMORY_REGION(base_, cap_);
    ASAN_UNPOISON_MEMORY_REGION(p, bytes);
    return p;
  }

 private:
  unsigned char* base_ = nullptr;
  size_t cap_ = 0;
};

}  // namespace ffseg_fuzz
