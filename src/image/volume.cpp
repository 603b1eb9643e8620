#include "volume.h"

#include "affine.h"

#include <cmath>
#include <cstdio>
#include <cstring>

namespace ffseg {

size_t voxel_type_size(uint32_t t) {
  switch (t) {
    case 1: return 1;
    case 2: case 3: return 2;
    case 4: case 5: return 4;
    case 6: return 8;
    default: return 0;
  }
}

double VolumeView::raw(const unsigned char* p) const {
  switch (type_) {
    case VoxelType::U8: return *p;
    case VoxelType::I16: { int16_t v; std::memcpy(&v, p, 2); return v; }
    case VoxelType::U16: { uint16_t v; std::memcpy(&v, p, 2); return v; }
    case VoxelType::I32: { int32_t v; std::memcpy(&v, p, 4); return v; }
    case VoxelType::F32: { float v; std::memcpy(&v, p, 4); return v; }
    case VoxelType::F64: { double v; std::memcpy(&v, p, 8); return v; }
  }
  return 0;
}

namespace {

bool fail(char* msg, size_t n, const char* text) {
  if (msg && n) std::snprintf(msg, n, "%s", text);
  return false;
}

// Inverts the 3x3 block of a 3x4 affine; false when singular.
bool invert_affine(const double A[12], double out[12]) {
  const double a = A[0], b = A[1], c = A[2], d = A[4], e = A[5], f = A[6], g = A[8], h = A[9], i = A[10];
  const double det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
  // |det| relative to the product of the column norms (the voxel edge lengths;
  // Hadamard: the ratio is in [0, 1] whatever the spacings): rejects
  // near-degenerate frames but accepts any anisotropy, as the NIfTI reader does.
  double scale = 1;
  for (int cc = 0; cc < 3; ++cc)
    scale *= std::sqrt(A[cc] * A[cc] + A[4 + cc] * A[4 + cc] + A[8 + cc] * A[8 + cc]);
  if (!(std::fabs(det) > 1e-12 * scale) || !std::isfinite(det)) return false;
  const double inv[9] = {(e * i - f * h) / det, (c * h - b * i) / det, (b * f - c * e) / det,
                         (f * g - d * i) / det, (a * i - c * g) / det, (c * d - a * f) / det,
                         (d * h - e * g) / det, (b * g - a * h) / det, (a * e - b * d) / det};
  for (int r = 0; r < 3; ++r) {
    for (int cc = 0; cc < 3; ++cc) out[4 * r + cc] = inv[3 * r + cc];
    out[4 * r + 3] = -(inv[3 * r] * A[3] + inv[3 * r + 1] * A[7] + inv[3 * r + 2] * A[11]);
  }
  return true;
}

}  // namespace

bool VolumeView::assign(const VolumeDesc& d, char* msg, size_t n) {
  const size_t es = voxel_type_size(d.type);
  if (es == 0) {
    if (msg) std::snprintf(msg, n, "volume: unknown voxel_type %u (expected 1..6)", d.type);
    return false;
  }
  if (d.data == nullptr) return fail(msg, n, "volume: data is NULL");
  for (int a = 0; a < 3; ++a)
    if (d.dims[a] < 1) {
      if (msg) std::snprintf(msg, n, "volume: dims[%d] = %lld, must be >= 1", a, (long long)d.dims[a]);
      return false;
    }
  {
    __int128 prod = 1;
    for (int a = 0; a < 3; ++a) {
      prod *= d.dims[a];
      if (prod > (__int128)INT64_MAX) return fail(msg, n, "volume: dims product overflows 64 bits");
    }
    if (prod * (__int128)es > (__int128)INT64_MAX)
      return fail(msg, n, "volume: voxel count times voxel size overflows 64 bits");
  }
  // A single slice has no extent along one axis: a closed surface cannot
  // bound anything in it, and a "segmentation" of it would be an artefact.
  for (int a = 0; a < 3; ++a)
    if (d.dims[a] == 1) {
      if (msg)
        std::snprintf(msg, n,
                      "volume: dims[%d] = 1, a single slice: a 3-D segmentation needs at least 2 voxels along "
                      "every axis",
                      a);
      return false;
    }
  // Byte range touched: offset + sum of the extreme steps along each axis.
  __int128 lo = d.offset, hi = d.offset;
  for (int a = 0; a < 3; ++a) {
    const __int128 span = (__int128)(d.dims[a] - 1) * d.strides[a];
    if (span < 0) lo += span; else hi += span;
  }
  hi += es;
  if (lo < 0)
    return fail(msg, n, "volume: strides/offset step before the start of data");
  if (hi > (__int128)d.data_bytes) {
    if (msg)
      std::snprintf(msg, n, "volume: strides/offset step past the end of data (needs %lld bytes, data_bytes is %llu)",
                    (long long)(hi > (__int128)INT64_MAX ? INT64_MAX : (int64_t)hi),
                    (unsigned long long)d.data_bytes);
    return false;
  }
  // Voxels must not overlap: sorted by |stride|, each axis must step over the
  // whole extent of the axes below it.
  {
    int order[3] = {0, 1, 2};
    __int128 as[3];
    for (int a = 0; a < 3; ++a) as[a] = d.strides[a] < 0 ? -(__int128)d.strides[a] : d.strides[a];
    for (int x = 1; x < 3; ++x)
      for (int y = x; y > 0 && as[order[y]] < as[order[y - 1]]; --y) {
        const int t = order[y]; order[y] = order[y - 1]; order[y - 1] = t;
      }
    __int128 extent = es;
    for (int x = 0; x < 3; ++x) {
      const int a = order[x];
      if (d.dims[a] == 1) continue;
      if (as[a] < extent) {
        if (msg)
          std::snprintf(msg, n, "volume: strides alias: |strides[%d]| = %lld is smaller than the %lld bytes it must step over",
                        a, (long long)d.strides[a], (long long)extent);
        return false;
      }
      extent = as[a] * (d.dims[a] - 1) + extent;
    }
  }
  const double* M = d.index_to_world;
  for (int q = 0; q < 16; ++q)
    if (!std::isfinite(M[q])) return fail(msg, n, "volume: index_to_world has a non-finite entry");
  if (M[12] != 0 || M[13] != 0 || M[14] != 0 || M[15] != 1)
    return fail(msg, n, "volume: index_to_world last row must be 0 0 0 1");
  double inv[12];
  if (!invert_affine(M, inv)) return fail(msg, n, "volume: index_to_world is singular");
  if (!std::isfinite(d.slope) || d.slope == 0)
    return fail(msg, n, "volume: rescale_slope must be finite and non-zero");
  if (!std::isfinite(d.intercept)) return fail(msg, n, "volume: rescale_intercept must be finite");

  type_ = VoxelType(d.type);
  origin_ = static_cast<const unsigned char*>(d.data) + d.offset;
  for (int a = 0; a < 3; ++a) {
    dims_[a] = d.dims[a];
    strides_[a] = d.strides[a];
    spacing_[a] = std::sqrt(M[a] * M[a] + M[4 + a] * M[4 + a] + M[8 + a] * M[8 + a]);
  }
  for (int q = 0; q < 12; ++q) { A_[q] = M[q]; Ainv_[q] = inv[q]; }
  slope_ = d.slope;
  intercept_ = d.intercept;
  return true;
}

VolumeView VolumeView::cell_geometry(const int64_t f[3]) const {
  VolumeView c;
  for (int a = 0; a < 3; ++a) {
    const double fa = double(f[a]), centre = 0.5 * (fa - 1);
    c.dims_[a] = (dims_[a] + f[a] - 1) / f[a];
    c.spacing_[a] = spacing_[a] * fa;
    // Column a of the affine scaled by f; the origin moved to cell 0's centre.
    for (int r = 0; r < 3; ++r) c.A_[4 * r + a] = A_[4 * r + a] * fa;
    // Row a of the inverse: (voxel index - centre) / f.
    for (int q = 0; q < 3; ++q) c.Ainv_[4 * a + q] = Ainv_[4 * a + q] / fa;
    c.Ainv_[4 * a + 3] = (Ainv_[4 * a + 3] - centre) / fa;
  }
  for (int r = 0; r < 3; ++r)
    c.A_[4 * r + 3] = A_[4 * r + 3] + 0.5 * (A_[4 * r] * double(f[0] - 1) + A_[4 * r + 1] * double(f[1] - 1) +
                                             A_[4 * r + 2] * double(f[2] - 1));
  return c;
}

double VolumeView::min_spacing() const {
  double m = spacing_[0];
  if (spacing_[1] < m) m = spacing_[1];
  if (spacing_[2] < m) m = spacing_[2];
  return m;
}

double VolumeView::max_spacing() const { return std::fmax(spacing_[0], std::fmax(spacing_[1], spacing_[2])); }

double VolumeView::sample_nearest(const double w[3], double outside) const {
  double p[3];
  world_to_index(w, p);
  int64_t q[3];
  for (int a = 0; a < 3; ++a) {
    if (!(p[a] >= -0.5 && p[a] < double(dims_[a]) - 0.5)) return outside;
    q[a] = int64_t(std::floor(p[a] + 0.5));
    if (q[a] >= dims_[a]) q[a] = dims_[a] - 1;
  }
  return at(q[0], q[1], q[2]);
}

double VolumeView::sample_linear(const double w[3], double outside) const {
  double p[3];
  world_to_index(w, p);
  int64_t q[3];
  double f[3];
  for (int a = 0; a < 3; ++a) {
    // Beyond one voxel past the grid every corner is outside.
    if (!(p[a] > -1.0 && p[a] < double(dims_[a]))) return outside;
    const double fl = std::floor(p[a]);
    q[a] = int64_t(fl);
    f[a] = p[a] - fl;
  }
  double acc = 0;
  for (int c = 0; c < 8; ++c) {
    const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
    const double wgt = (dx ? f[0] : 1 - f[0]) * (dy ? f[1] : 1 - f[1]) * (dz ? f[2] : 1 - f[2]);
    if (wgt == 0) continue;
    acc += wgt * at_or(q[0] + dx, q[1] + dy, q[2] + dz, outside);
  }
  return acc;
}

bool VolumeView::ball_meets_grid(const double c[3], double r) const {
  // Minimise |A p - c|^2 over the box p in [-0.5, dims - 0.5]^3 by exact
  // coordinate descent (convex, box-constrained); the grid's box is a
  // parallelepiped in world space.
  double p[3];
  world_to_index(c, p);
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = -0.5;
    hi[a] = double(dims_[a]) - 0.5;
    p[a] = p[a] < lo[a] ? lo[a] : (p[a] > hi[a] ? hi[a] : p[a]);
  }
  double G[9];  // A^T A
  for (int x = 0; x < 3; ++x)
    for (int y = 0; y < 3; ++y)
      G[3 * x + y] = A_[x] * A_[y] + A_[4 + x] * A_[4 + y] + A_[8 + x] * A_[8 + y];
  double best = 0;
  for (int sweep = 0; sweep < 200; ++sweep) {
    for (int a = 0; a < 3; ++a) {
      double w[3];
      index_to_world(p, w);
      const double rr[3] = {w[0] - c[0], w[1] - c[1], w[2] - c[2]};
      const double grad = A_[a] * rr[0] + A_[4 + a] * rr[1] + A_[8 + a] * rr[2];
      double np = p[a] - grad / G[4 * a];
      np = np < lo[a] ? lo[a] : (np > hi[a] ? hi[a] : np);
      p[a] = np;
    }
    double w[3];
    index_to_world(p, w);
    const double dd = (w[0] - c[0]) * (w[0] - c[0]) + (w[1] - c[1]) * (w[1] - c[1]) + (w[2] - c[2]) * (w[2] - c[2]);
    if (dd <= r * r) return true;
    if (sweep > 0 && dd >= best * (1 - 1e-12)) { best = dd; break; }
    best = dd;
  }
  return best <= r * r;
}

}  // namespace ffseg
