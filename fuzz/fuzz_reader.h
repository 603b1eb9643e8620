// Splits a fuzz input into fixed-size fields; reads past the end yield zeros.
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstring>

namespace ffseg_fuzz {

struct Reader {
  const uint8_t* p;
  size_t n;
  template <class T>
  T take() {
    T v;
    std::memset(&v, 0, sizeof v);
    const size_t k = n < sizeof v ? n : sizeof v;
    std::memcpy(&v, p, k);
    p += k;
    n -= k;
    return v;
  }
  bool empty() const { return n == 0; }
};

// FNV-1a: a mutation anywhere in the input changes it (for gates that let
// only a share of the inputs take an expensive path).
inline uint32_t input_hash(const uint8_t* p, size_t n) {
  uint32_t h = 2166136261u;
  for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 16777619u;
  return h;
}

}  // namespace ffseg_fuzz
