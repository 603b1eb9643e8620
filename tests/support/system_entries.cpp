#include "system_entries.h"

#include <utility>

namespace ffseg_test {

std::vector<Entry> cube_sphere_system(uint32_t nv, const uint32_t* nbr, double lL, double lP, double lU,
                                      const std::vector<double>& w) {
  std::vector<Entry> t;
  t.reserve(std::size_t(nv) * 20);
  auto put = [&](uint32_t a, uint32_t b, double v) {
    if (a < b) std::swap(a, b);
    t.push_back({a, b, v});
  };
  for (uint32_t i = 0; i < nv; ++i) {
    const uint32_t idx[5] = {i, nbr[4 * i], nbr[4 * i + 1], nbr[4 * i + 2], nbr[4 * i + 3]};
    const double val[5] = {1.0, -0.25, -0.25, -0.25, -0.25};
    for (int a = 0; a < 5; ++a)
      for (int b = 0; b <= a; ++b) {
        double v = lL * val[a] * val[b];
        if (a != b && idx[a] == idx[b]) v *= 2;
        put(idx[a], idx[b], v);
      }
    if (w[i] != 0) put(i, i, lP * w[i]);
    for (int k = 0; k < 4; ++k) {
      const uint32_t j = nbr[4 * i + k];
      if (j > i) {  // every edge once: C^T C
        put(i, i, lU);
        put(j, j, lU);
        put(i, j, -lU);
      }
    }
  }
  return t;
}

}  // namespace ffseg_test
