#include "phantoms.h"

#include <cmath>

namespace ffseg_test {

size_t Phantom::count() const {
  size_t c = 0;
  for (uint8_t m : mask) c += m != 0;
  return c;
}

void Phantom::world(double i, double j, double k, double w[3]) const {
  for (int r = 0; r < 3; ++r)
    w[r] = affine[4 * r] * i + affine[4 * r + 1] * j + affine[4 * r + 2] * k + affine[4 * r + 3];
}

Phantom make_phantom(const int64_t dims[3], const double affine[16],
                     const std::function<bool(const double w[3])>& inside) {
  Phantom p;
  for (int a = 0; a < 3; ++a) p.dims[a] = dims[a];
  for (int q = 0; q < 16; ++q) p.affine[q] = affine[q];
  p.mask.assign(size_t(dims[0] * dims[1] * dims[2]), 0);
  for (int64_t k = 0; k < dims[2]; ++k)
    for (int64_t j = 0; j < dims[1]; ++j)
      for (int64_t i = 0; i < dims[0]; ++i) {
        double w[3];
        p.world(double(i), double(j), double(k), w);
        p.mask[size_t(i + dims[0] * (j + dims[1] * k))] = inside(w) ? 1 : 0;
      }
  return p;
}

Phantom ball_phantom(int64_t dim, const double c[3], double r) {
  const int64_t dims[3] = {dim, dim, dim};
  const double A[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  Phantom p = make_phantom(dims, A, [&](const double w[3]) {
    return (w[0] - c[0]) * (w[0] - c[0]) + (w[1] - c[1]) * (w[1] - c[1]) + (w[2] - c[2]) * (w[2] - c[2]) <= r * r;
  });
  for (int a = 0; a < 3; ++a) p.center[a] = c[a];
  return p;
}

Phantom ellipsoid_phantom() {
  // Grid: spacing 0.7 x 0.9 x 2.5 mm, rotated 25 degrees about z and 10 about x.
  const double az = 25 * M_PI / 180, ax = 10 * M_PI / 180;
  const double Rz[9] = {std::cos(az), -std::sin(az), 0, std::sin(az), std::cos(az), 0, 0, 0, 1};
  const double Rx[9] = {1, 0, 0, 0, std::cos(ax), -std::sin(ax), 0, std::sin(ax), std::cos(ax)};
  double R[9];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      R[3 * r + c] = 0;
      for (int k = 0; k < 3; ++k) R[3 * r + c] += Rz[3 * r + k] * Rx[3 * k + c];
    }
  const double sp[3] = {0.7, 0.9, 2.5};
  const int64_t dims[3] = {110, 90, 36};
  double A[16] = {0};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) A[4 * r + c] = R[3 * r + c] * sp[c];
  A[3] = -20; A[7] = 12; A[11] = -30; A[15] = 1;
  Phantom p;
  p.dims[0] = dims[0];
  // Centre of the grid in world mm.
  double ctr[3];
  for (int r = 0; r < 3; ++r)
    ctr[r] = A[4 * r] * (dims[0] - 1) / 2.0 + A[4 * r + 1] * (dims[1] - 1) / 2.0 + A[4 * r + 2] * (dims[2] - 1) / 2.0 + A[4 * r + 3];
  // The ellipsoid's own axes: rotated 40 degrees about y relative to world.
  const double ay = 40 * M_PI / 180;
  const double semi[3] = {28, 18, 24};
  p = make_phantom(dims, A, [&](const double w[3]) {
    const double d[3] = {w[0] - ctr[0], w[1] - ctr[1], w[2] - ctr[2]};
    const double e0 = std::cos(ay) * d[0] + std::sin(ay) * d[2];
    const double e1 = d[1];
    const double e2 = -std::sin(ay) * d[0] + std::cos(ay) * d[2];
    return (e0 * e0) / (semi[0] * semi[0]) + (e1 * e1) / (semi[1] * semi[1]) + (e2 * e2) / (semi[2] * semi[2]) <= 1.0;
  });
  for (int a = 0; a < 3; ++a) p.center[a] = ctr[a];
  return p;
}

Phantom cup_phantom() {
  const int64_t dims[3] = {128, 128, 128};
  const double A[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  const double cx = 63.5, cy = 63.5;
  const double z0 = 26, z1 = 102;         // bottom and rim height
  const double ro = 40, ri = 27, bottom = 16;  // outer radius, cavity radius, floor thickness
  Phantom p = make_phantom(dims, A, [&](const double w[3]) {
    const double rho = std::sqrt((w[0] - cx) * (w[0] - cx) + (w[1] - cy) * (w[1] - cy));
    if (w[2] < z0 || w[2] > z1) return false;
    // Rounded outer bottom edge (radius 8 mm).
    const double rb = 8;
    if (w[2] < z0 + rb && rho > ro - rb) {
      const double dz = z0 + rb - w[2], dr = rho - (ro - rb);
      if (dz * dz + dr * dr > rb * rb) return false;
    }
    if (rho > ro) return false;
    // Cavity: open at the top, flat floor.
    if (rho < ri && w[2] > z0 + bottom) return false;
    return true;
  });
  p.center[0] = cx;
  p.center[1] = cy;
  p.center[2] = 0.5 * (z0 + z1);
  return p;
}

double dice(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
  size_t na = 0, nb = 0, both = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    const bool x = a[i] != 0, y = b[i] != 0;
    na += x;
    nb += y;
    both += x && y;
  }
  return na + nb ? 2.0 * double(both) / double(na + nb) : 1.0;
}

}  // namespace ffseg_test
