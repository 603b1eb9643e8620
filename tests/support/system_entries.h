// The deformation system lL A^T A + lP W + lU C^T C of a mesh with four
// neighbours per vertex, as lower-triangle entries (i >= j, repeated: sum
// them), for reference solvers in tests and benchmarks.
#pragma once
#include <cstdint>
#include <vector>

namespace ffseg_test {

struct Entry {
  uint32_t i, j;
  double v;
};

std::vector<Entry> cube_sphere_system(uint32_t nv, const uint32_t* nbr, double lL, double lP, double lU,
                                      const std::vector<double>& w);

}  // namespace ffseg_test
