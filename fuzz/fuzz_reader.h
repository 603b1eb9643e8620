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

}  // namespace ffseg_fuzz
