// Segmentation accuracy metrics. See metrics.h for definitions and conventions.
//
// Distance transform: Felzenszwalb & Huttenlocher, "Distance Transforms of
// Sampled Functions" (2012): the squared EDT is separable, and each 1D pass is
// the lower envelope of parabolas w*(q-p)^2 + f(p), w = spacing^2 of that axis.
// All squared distances are computed in double with the real spacing, so the
// result is exact up to rounding.
#include "metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace ffseg_tools {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

void check_args(const void* mask, const int dims[3], const double spacing[3]) {
  if (!dims || !spacing) throw std::invalid_argument("ffseg_tools: null dims/spacing");
  for (int a = 0; a < 3; ++a) {
    if (dims[a] < 0) throw std::invalid_argument("ffseg_tools: negative dimension");
    if (!(spacing[a] > 0.0) || !std::isfinite(spacing[a]))
      throw std::invalid_argument("ffseg_tools: spacing must be positive and finite");
  }
  if (!mask && dims[0] > 0 && dims[1] > 0 && dims[2] > 0)
    throw std::invalid_argument("ffseg_tools: null mask");
}

std::size_t voxel_count(const int dims[3]) {
  return std::size_t(dims[0]) * std::size_t(dims[1]) * std::size_t(dims[2]);
}

// 1D squared distance transform of f (kInf = not a site) with weight w:
// d[q] = min_p w*(q-p)^2 + f[p]. v (n ints) and z (n+1 doubles) are scratch.
void dt1d(const double* f, int n, double w, double* d, int* v, double* z) {
  int k = -1;
  for (int q = 0; q < n; ++q) {
    if (f[q] == kInf) continue;
    const double hq = f[q] + w * double(q) * double(q);
    if (k < 0) {
      k = 0;
      v[0] = q;
      z[0] = -kInf;
      z[1] = kInf;
      continue;
    }
    double s;
    for (;;) {  // z[0] = -inf stops the loop at k = 0
      const int p = v[k];
      s = (hq - (f[p] + w * double(p) * double(p))) / (2.0 * w * double(q - p));
      if (s > z[k]) break;
      --k;
    }
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = kInf;
  }
  if (k < 0) {
    std::fill(d, d + n, kInf);
    return;
  }
  int j = 0;
  for (int q = 0; q < n; ++q) {
    while (z[j + 1] < double(q)) ++j;
    const double dq = double(q - v[j]);
    d[q] = w * dq * dq + f[v[j]];
  }
}

// Squared EDT over a box of size bd (row-major, i fastest) whose input `out`
// holds 0 at sites and kInf elsewhere; transformed in place.
void edt_inplace(std::vector<double>& out, const int bd[3], const double sp[3]) {
  const int nmax = std::max({bd[0], bd[1], bd[2], 1});
  std::vector<double> f(nmax), d(nmax), z(nmax + 1);
  std::vector<int> v(nmax);
  const std::size_t stride[3] = {1, std::size_t(bd[0]), std::size_t(bd[0]) * std::size_t(bd[1])};
  for (int axis = 0; axis < 3; ++axis) {
    const int n = bd[axis];
    const int o1 = axis == 0 ? 1 : 0, o2 = axis == 2 ? 1 : 2;  // the other two axes
    const double w = sp[axis] * sp[axis];
    const std::size_t st = stride[axis];
    for (int b = 0; b < bd[o2]; ++b)
      for (int a = 0; a < bd[o1]; ++a) {
        const std::size_t base = std::size_t(a) * stride[o1] + std::size_t(b) * stride[o2];
        bool any = false;
        for (int q = 0; q < n; ++q) {
          f[q] = out[base + q * st];
          any = any || f[q] != kInf;
        }
        if (!any) continue;  // stays all-infinite
        dt1d(f.data(), n, w, d.data(), v.data(), z.data());
        for (int q = 0; q < n; ++q) out[base + q * st] = d[q];
      }
  }
}

// Border test for object voxel (i,j,k): any of the 26 neighbours is outside the
// grid or zero.
bool is_border(const uint8_t* m, const int dims[3], int i, int j, int k) {
  if (i == 0 || j == 0 || k == 0 || i == dims[0] - 1 || j == dims[1] - 1 || k == dims[2] - 1) return true;
  const std::size_t sj = std::size_t(dims[0]), sk = sj * std::size_t(dims[1]);
  const uint8_t* c = m + std::size_t(i) + sj * std::size_t(j) + sk * std::size_t(k);
  for (int dk = -1; dk <= 1; ++dk)
    for (int dj = -1; dj <= 1; ++dj) {
      const uint8_t* r = c + std::ptrdiff_t(dk) * std::ptrdiff_t(sk) + std::ptrdiff_t(dj) * std::ptrdiff_t(sj);
      if (!r[-1] || !r[0] || !r[1]) return true;
    }
  return false;
}

// Distances from each voxel of `from` (linear indices, ascending) to the
// nearest voxel of the border mask `to`, appended to `dist`. Only the bounding
// box [lo, hi] of both index sets is transformed: every site and every query
// lies inside it, so the result is exact.
void directed_distances(const std::vector<std::size_t>& from, const uint8_t* to_mask,
                        const int dims[3], const double sp[3], const int lo[3], const int hi[3],
                        std::vector<double>& buf, std::vector<double>& dist) {
  const int bd[3] = {hi[0] - lo[0] + 1, hi[1] - lo[1] + 1, hi[2] - lo[2] + 1};
  buf.assign(std::size_t(bd[0]) * std::size_t(bd[1]) * std::size_t(bd[2]), kInf);
  const std::size_t sj = std::size_t(dims[0]), sk = sj * std::size_t(dims[1]);
  std::size_t p = 0;
  for (int k = lo[2]; k <= hi[2]; ++k)
    for (int j = lo[1]; j <= hi[1]; ++j) {
      const uint8_t* row = to_mask + std::size_t(k) * sk + std::size_t(j) * sj;
      for (int i = lo[0]; i <= hi[0]; ++i, ++p)
        if (row[i]) buf[p] = 0.0;
    }
  edt_inplace(buf, bd, sp);
  for (std::size_t idx : from) {
    const int i = int(idx % sj), j = int((idx / sj) % std::size_t(dims[1])), k = int(idx / sk);
    const std::size_t q = std::size_t(i - lo[0]) + std::size_t(bd[0]) * (std::size_t(j - lo[1]) + std::size_t(bd[1]) * std::size_t(k - lo[2]));
    dist.push_back(std::sqrt(buf[q]));
  }
}

}  // namespace

std::vector<double> edt_sq_mm2(const uint8_t* mask, const int dims[3], const double spacing[3],
                               bool target_nonzero) {
  check_args(mask, dims, spacing);
  const std::size_t n = voxel_count(dims);
  std::vector<double> out(n);
  for (std::size_t i = 0; i < n; ++i) out[i] = ((mask[i] != 0) == target_nonzero) ? 0.0 : kInf;
  if (n) edt_inplace(out, dims, spacing);
  return out;
}

std::vector<double> edt_mm(const uint8_t* mask, const int dims[3], const double spacing[3],
                           bool target_nonzero) {
  std::vector<double> d = edt_sq_mm2(mask, dims, spacing, target_nonzero);
  for (double& x : d) x = std::sqrt(x);
  return d;
}

std::size_t border_mask(const uint8_t* mask, const int dims[3], uint8_t* out) {
  const double one[3] = {1, 1, 1};
  check_args(mask, dims, one);
  std::size_t count = 0, p = 0;
  for (int k = 0; k < dims[2]; ++k)
    for (int j = 0; j < dims[1]; ++j)
      for (int i = 0; i < dims[0]; ++i, ++p) {
        const bool b = mask[p] && is_border(mask, dims, i, j, k);
        out[p] = b ? 1 : 0;
        count += b;
      }
  return count;
}

bool find_deepest_voxel(const uint8_t* mask, const int dims[3], const double spacing[3],
                        std::array<int, 3>* ijk, double* dist_mm) {
  check_args(mask, dims, spacing);
  // bounding box of the object
  int lo[3] = {dims[0], dims[1], dims[2]}, hi[3] = {-1, -1, -1};
  std::size_t p = 0;
  for (int k = 0; k < dims[2]; ++k)
    for (int j = 0; j < dims[1]; ++j)
      for (int i = 0; i < dims[0]; ++i, ++p)
        if (mask[p]) {
          lo[0] = std::min(lo[0], i); hi[0] = std::max(hi[0], i);
          lo[1] = std::min(lo[1], j); hi[1] = std::max(hi[1], j);
          lo[2] = std::min(lo[2], k); hi[2] = std::max(hi[2], k);
        }
  if (hi[0] < 0) return false;
  // Box grown by one voxel on every side (possibly beyond the grid). Its outer
  // layer is all background, and for any object voxel the nearest background
  // voxel can be clamped into this box without getting farther, so the EDT of
  // the box is exact. Voxels beyond the grid are background sites.
  for (int a = 0; a < 3; ++a) { --lo[a]; ++hi[a]; }
  const int bd[3] = {hi[0] - lo[0] + 1, hi[1] - lo[1] + 1, hi[2] - lo[2] + 1};
  const std::size_t nbox = std::size_t(bd[0]) * std::size_t(bd[1]) * std::size_t(bd[2]);
  std::vector<double> buf(nbox);
  const std::size_t sj = std::size_t(dims[0]), sk = sj * std::size_t(dims[1]);
  p = 0;
  for (int k = lo[2]; k <= hi[2]; ++k)
    for (int j = lo[1]; j <= hi[1]; ++j)
      for (int i = lo[0]; i <= hi[0]; ++i, ++p) {
        const bool inside = i >= 0 && j >= 0 && k >= 0 && i < dims[0] && j < dims[1] && k < dims[2];
        const bool obj = inside && mask[std::size_t(i) + sj * std::size_t(j) + sk * std::size_t(k)];
        buf[p] = obj ? kInf : 0.0;
      }
  edt_inplace(buf, bd, spacing);
  // Depths equal but for rounding (spacings read back from a DICOM series'
  // decimal strings differ from the NIfTI's in the 10th digit) count as a
  // tie, so the protocol sphere does not depend on the file's format. Box
  // order is grid order restricted to the box, so the first voxel within the
  // tie of the maximum is the one with the lowest linear index.
  double top = 0;
  for (std::size_t q = 0; q < nbox; ++q) top = std::max(top, buf[q]);
  const double tie = top * (1 - 1e-9);
  double best = -1.0;
  int bi = 0, bj = 0, bk = 0;
  p = 0;
  for (int k = lo[2]; k <= hi[2] && best < 0; ++k)
    for (int j = lo[1]; j <= hi[1] && best < 0; ++j)
      for (int i = lo[0]; i <= hi[0]; ++i, ++p)
        if (buf[p] > 0 && buf[p] >= tie) {  // background voxels have 0
          best = buf[p];
          bi = i; bj = j; bk = k;
          break;
        }
  if (ijk) *ijk = {bi, bj, bk};
  if (dist_mm) *dist_mm = std::sqrt(best);
  return true;
}

SegMetrics compare_masks(const uint8_t* a, const uint8_t* b, const int dims[3],
                         const double spacing[3]) {
  check_args(a, dims, spacing);
  check_args(b, dims, spacing);
  const std::size_t n = voxel_count(dims);
  const double voxel_ml = spacing[0] * spacing[1] * spacing[2] / 1000.0;

  std::size_t na = 0, nb = 0, nab = 0;
  std::vector<std::size_t> border_a, border_b;
  std::vector<uint8_t> bmask_a(n, 0), bmask_b(n, 0);
  int lo[3] = {dims[0], dims[1], dims[2]}, hi[3] = {-1, -1, -1};
  std::size_t p = 0;
  for (int k = 0; k < dims[2]; ++k)
    for (int j = 0; j < dims[1]; ++j)
      for (int i = 0; i < dims[0]; ++i, ++p) {
        const bool ia = a[p] != 0, ib = b[p] != 0;
        na += ia;
        nb += ib;
        nab += ia && ib;
        bool any = false;
        if (ia && is_border(a, dims, i, j, k)) {
          border_a.push_back(p);
          bmask_a[p] = 1;
          any = true;
        }
        if (ib && is_border(b, dims, i, j, k)) {
          border_b.push_back(p);
          bmask_b[p] = 1;
          any = true;
        }
        if (any) {
          lo[0] = std::min(lo[0], i); hi[0] = std::max(hi[0], i);
          lo[1] = std::min(lo[1], j); hi[1] = std::max(hi[1], j);
          lo[2] = std::min(lo[2], k); hi[2] = std::max(hi[2], k);
        }
      }

  SegMetrics m{};
  m.vol_a_ml = double(na) * voxel_ml;
  m.vol_b_ml = double(nb) * voxel_ml;
  m.border_a = border_a.size();
  m.border_b = border_b.size();
  const std::size_t nunion = na + nb - nab;
  if (na == 0 && nb == 0) {  // identical (empty) masks
    m.dice = 1.0;
    m.voe = 0.0;
    m.rvd = 0.0;
    m.assd_mm = m.hd95_mm = m.hd_mm = 0.0;
    return m;
  }
  m.dice = 2.0 * double(nab) / double(na + nb);
  m.voe = 1.0 - double(nab) / double(nunion);
  m.rvd = nb ? (double(na) - double(nb)) / double(nb) : kInf;
  if (na == 0 || nb == 0) {
    m.assd_mm = m.hd95_mm = m.hd_mm = kInf;
    return m;
  }

  std::vector<double> dist, buf;
  dist.reserve(border_a.size() + border_b.size());
  directed_distances(border_a, bmask_b.data(), dims, spacing, lo, hi, buf, dist);
  directed_distances(border_b, bmask_a.data(), dims, spacing, lo, hi, buf, dist);

  double sum = 0.0, mx = 0.0;
  for (double d : dist) {
    sum += d;
    mx = std::max(mx, d);
  }
  m.assd_mm = sum / double(dist.size());
  m.hd_mm = mx;
  // nearest rank: 1-based rank ceil(0.95 * N); integer arithmetic avoids
  // rounding 0.95 * N
  const std::size_t N = dist.size();
  const std::size_t rank = (95 * N + 99) / 100;  // ceil(0.95 N), >= 1
  std::nth_element(dist.begin(), dist.begin() + std::ptrdiff_t(rank - 1), dist.end());
  m.hd95_mm = dist[rank - 1];
  return m;
}

}  // namespace ffseg_tools
