// Synthetic binary volumes with known answers, generated in the tests.
#pragma once
#include <cstdint>
#include <functional>
#include <vector>

namespace ffseg_test {

struct Phantom {
  int64_t dims[3] = {0, 0, 0};
  double affine[16] = {};  // index -> world, row-major
  std::vector<uint8_t> mask;
  double center[3] = {0, 0, 0};  // a point the tests may use (mm)
  size_t count() const;
  void world(double i, double j, double k, double w[3]) const;
};

// Fills a grid of dims with `affine` from an inside test in world mm.
Phantom make_phantom(const int64_t dims[3], const double affine[16],
                     const std::function<bool(const double w[3])>& inside);

// A ball of radius r (mm) at c on an isotropic 1 mm grid of dims.
Phantom ball_phantom(int64_t dim, const double c[3], double r);
// An ellipsoid with semi-axes (a, b, c) mm, rotated, on a rotated grid with
// spacing 0.7 x 0.9 x 2.5 mm.
Phantom ellipsoid_phantom();
// The thesis' cup (fig. 4.13): a thick-walled cup with a deep cavity open
// along +z, about 128^3 voxels of 1 mm.
Phantom cup_phantom();

// Dice between two masks of the same size.
double dice(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b);

}  // namespace ffseg_test
