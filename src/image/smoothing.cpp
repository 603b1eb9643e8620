#include "smoothing.h"

#include "affine.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <cstdlib>

#include "box_lattice.h"
#include "cpu_x86.h"
#include "smoothing_sweep.h"

#include "fp_contract_off.h"  // after every other include

namespace ffseg {

namespace {

using namespace smoothing_kernels;

float nth_of(float* v, int64_t n, int64_t k) {
  std::nth_element(v, v + k, v + n);
  return v[k];
}

int64_t clamp_to_index(double v, int64_t lo, int64_t hi) {
  if (!(v > double(lo))) return lo;  // also NaN
  if (!(v < double(hi))) return hi;
  return int64_t(v);
}

}  // namespace

int64_t SmoothedRoi::plane_capacity(int64_t max_voxels) {
  if (max_voxels <= 0) return 0;
  // A plane of the region (longest axis slowest) holds P / max_extent <= P^(2/3) voxels.
  int64_t c = int64_t(std::ceil(std::pow(double(max_voxels), 2.0 / 3.0))) + 2;
  return c > max_voxels ? max_voxels : c;
}

int64_t SmoothedRoi::scratch_floats(int64_t max_voxels) {
  if (max_voxels <= 0) return 0;
  // Two sweep planes (a zero float before, between and after), then the
  // face fluxes: two planes for the w faces, the row's u faces and two rows
  // for its v faces (kFluxPad floats around each).
  const int64_t n = 7 * plane_capacity(max_voxels) + 3 + 12 * kFluxPad;
  return n < 7 * int64_t(kNoisePoints) ? 7 * int64_t(kNoisePoints) : n;
}

void SmoothedRoi::carve(Arena& a, int64_t max_voxels, const CpuDispatch& cpu) {
  cpu_ = cpu;
  room_ = nullptr;
  max_voxels_ = max_voxels > 0 ? max_voxels : 0;
  plane_cap_ = plane_capacity(max_voxels_);
  scratch_len_ = scratch_floats(max_voxels_);
  buf_ = a.alloc<float>(size_t(max_voxels_));
  scratch_ = a.alloc<float>(size_t(scratch_len_));
  valid_ = false;
}

void SmoothedRoi::carve_in(CropPool& room, uint32_t slot, int64_t max_voxels, float* scratch,
                           const CpuDispatch& cpu) {
  cpu_ = cpu;
  room_ = &room;
  slot_ = slot;
  max_voxels_ = max_voxels > 0 ? max_voxels : 0;
  plane_cap_ = plane_capacity(room.capacity());
  scratch_len_ = scratch_floats(room.capacity());
  scratch_ = scratch;
  room.attach(slot, &buf_);  // buf_: nullptr until compute() takes a span
  valid_ = false;
}

namespace {

// Rows of raw integer voxels to floats: value = slope * raw + intercept in
// double, then float, as VolumeView::for_each_in_row and the generic copy do;
// the raw extremes are tracked instead of the values (the value is a monotone
// function of the raw one).
template <class T>
void copy_rows(const unsigned char* origin, const int64_t* strides, const int64_t* glo, const int64_t* ext,
               const int* ax, double slope, double intercept, float* out, T* rmin, T* rmax) {
  T lo = std::numeric_limits<T>::max(), hi = std::numeric_limits<T>::lowest();
  const int64_t s0 = strides[ax[0]], n0 = ext[ax[0]];
  for (int64_t w = 0; w < ext[ax[2]]; ++w)
    for (int64_t v = 0; v < ext[ax[1]]; ++v) {
      int64_t idx[3];
      idx[ax[0]] = glo[ax[0]];
      idx[ax[1]] = glo[ax[1]] + v;
      idx[ax[2]] = glo[ax[2]] + w;
      const unsigned char* p = origin + idx[0] * strides[0] + idx[1] * strides[1] + idx[2] * strides[2];
      if (s0 == int64_t(sizeof(T))) {
        for (int64_t t = 0; t < n0; ++t) {
          T r;
          std::memcpy(&r, p + t * int64_t(sizeof(T)), sizeof r);
          lo = r < lo ? r : lo;
          hi = r > hi ? r : hi;
          out[t] = float(slope * double(r) + intercept);
        }
      } else {
        for (int64_t t = 0; t < n0; ++t) {
          T r;
          std::memcpy(&r, p + t * s0, sizeof r);
          lo = r < lo ? r : lo;
          hi = r > hi ? r : hi;
          out[t] = float(slope * double(r) + intercept);
        }
      }
      out += n0;
    }
  *rmin = lo;
  *rmax = hi;
}

}  // namespace

bool SmoothedRoi::integer_copy_applies(const VolumeView& vol) {
  // Integer types up to 32 bits give finite values; the generic copy's clamp
  // to +-1e30 is a no-op when every representable value stays within it.
  const VoxelType t = vol.type();
  const bool integer = t == VoxelType::U8 || t == VoxelType::I16 || t == VoxelType::U16 || t == VoxelType::I32;
  return integer && std::fabs(vol.slope()) * 2147483648.0 + std::fabs(vol.intercept()) < 1e29;
}

bool SmoothedRoi::copy_integer(const VolumeView& vol, double* vmin, double* vmax) {
  const double slope = vol.slope(), icpt = vol.intercept();
  if (!integer_copy_applies(vol)) return false;
  double rlo = 0, rhi = 0;
  auto copy = [&](auto type_tag) {
    using T = decltype(type_tag);
    T a, b;
    copy_rows<T>(vol.origin(), vol.strides(), glo_, ext_, ax_, slope, icpt, buf_, &a, &b);
    rlo = a, rhi = b;
  };
  switch (vol.type()) {
    case VoxelType::U8: copy(uint8_t{}); break;
    case VoxelType::I16: copy(int16_t{}); break;
    case VoxelType::U16: copy(uint16_t{}); break;
    case VoxelType::I32: copy(int32_t{}); break;
    default: return false;
  }
  const double x0 = slope * rlo + icpt, x1 = slope * rhi + icpt;
  *vmin = slope > 0 ? x0 : x1;
  *vmax = slope > 0 ? x1 : x0;
  return true;
}

RoiStatus SmoothedRoi::compute(const VolumeView& vol, const int64_t lo_in[3], const int64_t hi_in[3],
                               const SmoothingSettings& s, char* msg, size_t msg_len) {
  valid_ = false;
  needed_ = 0;
  if (!vol.valid()) {
    if (msg && msg_len) std::snprintf(msg, msg_len, "smoothing: no valid volume");
    return RoiStatus::bad_volume;
  }
  const int64_t* D = vol.dims();
  const uint32_t margin = s.iterations;
  int64_t ext[3];
  for (int a = 0; a < 3; ++a) {
    grid_[a] = D[a];
    lo_[a] = std::max<int64_t>(0, std::min<int64_t>(lo_in[a], D[a]));
    hi_[a] = std::max<int64_t>(0, std::min<int64_t>(hi_in[a], D[a]));
    if (lo_[a] >= hi_[a]) {
      if (msg && msg_len) std::snprintf(msg, msg_len, "smoothing: the region does not meet the grid along axis %d", a);
      return RoiStatus::empty;
    }
    glo_[a] = lo_[a] - int64_t(margin) < 0 ? 0 : lo_[a] - int64_t(margin);
    ghi_[a] = D[a] - hi_[a] < int64_t(margin) ? D[a] : hi_[a] + int64_t(margin);
    ext[a] = ghi_[a] - glo_[a];
    ext_[a] = ext[a];
    in_lo_[a] = double(glo_[a]) - 0.5;
    in_hi_[a] = double(ghi_[a]) - 0.5;
    centre_lo_[a] = double(glo_[a]);
    centre_hi_[a] = double(ghi_[a] - 1);
    // The statistics' box: the given one within the requested box, else that box.
    slo_[a] = lo_[a];
    shi_[a] = hi_[a];
    if (s.stats_lo && s.stats_hi) {
      const int64_t l = std::max(lo_[a], s.stats_lo[a]), h = std::min(hi_[a], s.stats_hi[a]);
      if (l < h) slo_[a] = l, shi_[a] = h;
    }
  }
  needed_ = ext[0] * ext[1] * ext[2];  // <= the grid's voxel count, which fits
  const bool shared = room_ != nullptr && scratch_ != nullptr;
  if (!(shared && s.share_room) && needed_ > max_voxels_) {
    if (msg && msg_len)
      std::snprintf(msg, msg_len,
                    "smoothing region %lld x %lld x %lld = %lld voxels (box grown by %u voxels for %u iterations) "
                    "exceeds max_roi_voxels = %lld",
                    (long long)ext[0], (long long)ext[1], (long long)ext[2], (long long)needed_, margin, margin,
                    (long long)max_voxels_);
    return RoiStatus::too_large;
  }
  if (shared) {  // a span of the room (a previous one too short is given up: recomputed here anyway)
    valid_ = false;
    if (room_->acquire(slot_, needed_) == nullptr) {
      if (msg && msg_len)
        std::snprintf(msg, msg_len,
                      "smoothing region %lld x %lld x %lld = %lld voxels does not fit beside the other objects' "
                      "crops (%lld of the %lld voxels of their shared room held: max_objects x max_roi_voxels)",
                      (long long)ext[0], (long long)ext[1], (long long)ext[2], (long long)needed_,
                      (long long)room_->held(), (long long)room_->capacity());
      return RoiStatus::too_large;
    }
  }
  if (buf_ == nullptr || scratch_ == nullptr) {
    if (msg && msg_len) std::snprintf(msg, msg_len, "smoothing: region memory was not carved");
    return RoiStatus::not_carved;
  }
  // Storage order: longest axis slowest (ties: the higher index axis), so a
  // sweep plane is at most max_voxels^(2/3) voxels.
  int slow = 2;
  for (int a = 1; a >= 0; --a)
    if (ext[a] > ext[slow]) slow = a;
  ax_[2] = slow;
  ax_[0] = slow == 0 ? 1 : 0;
  ax_[1] = slow == 2 ? 1 : 2;
  st_[ax_[0]] = 1;
  st_[ax_[1]] = ext[ax_[0]];
  st_[ax_[2]] = ext[ax_[0]] * ext[ax_[1]];
  if (st_[ax_[2]] > plane_cap_) {  // cannot happen (see plane_capacity); kept as a guard
    if (msg && msg_len) std::snprintf(msg, msg_len, "smoothing: sweep plane exceeds its scratch");
    return RoiStatus::too_large;
  }
  for (int q = 0; q < 12; ++q) {
    A_[q] = vol.affine()[q];
    Ainv_[q] = vol.inverse()[q];
  }
  for (int a = 0; a < 3; ++a) h_[a] = vol.spacing()[a];

  if (s.statistics || !(s.kappa > 0) || !integer_copy_applies(vol)) {
    estimate_noise(vol);
  } else {  // not needed: kappa is given and no voxel can be non-finite
    sigma_n_ = sigma_d_ = p_lo_ = p_hi_ = c_lo_ = c_hi_ = 0;
    gain_ = 1;
    lag_ = 1;
    over_[0] = over_[1] = over_[2] = false;
    fence_lo_ = -INFINITY;
    fence_hi_ = INFINITY;
  }
  // Copy the raw region in.
  double vmin = INFINITY, vmax = -INFINITY;
  if (!copy_integer(vol, &vmin, &vmax)) {
    int64_t idx[3];
    float* out = buf_;
    for (int64_t w = 0; w < ext[ax_[2]]; ++w) {
      idx[ax_[2]] = glo_[ax_[2]] + w;
      for (int64_t v = 0; v < ext[ax_[1]]; ++v) {
        idx[ax_[1]] = glo_[ax_[1]] + v;
        idx[ax_[0]] = glo_[ax_[0]];
        const double plo = p_lo_;
        vol.for_each_in_row(idx[0], idx[1], idx[2], ax_[0], ext[ax_[0]], [&](int64_t, double x) {
          if (!std::isfinite(x)) x = plo;  // NaN / inf voxels (float volumes) read as the 1st percentile
          x = x < -1e30 ? -1e30 : (x > 1e30 ? 1e30 : x);  // finite in float, and so are differences
          vmin = x < vmin ? x : vmin;
          vmax = x > vmax ? x : vmax;
          *out++ = float(x);
        });
      }
    }
  }
  vmin_ = vmin;
  vmax_ = vmax;

  double hmin = std::min(h_[0], std::min(h_[1], h_[2]));
  double sig = std::max(sigma_n_, 1e-3 * (p_hi_ - p_lo_));
  kappa_ = s.kappa > 0 ? s.kappa : (sig > 0 ? 2.0 * sig / hmin : 1.0);
  double sum = 0;
  for (int a = 0; a < 3; ++a) sum += 1.0 / (h_[a] * h_[a]);
  dt_ = 0.75 / (2.0 * sum);
  diffuse(s.iterations);
  valid_ = true;
  return RoiStatus::ok;
}

void SmoothedRoi::estimate_noise(const VolumeView& vol) {
  // Voxels of a lattice that flips and axis permutations map onto itself
  // (box_lattice.h), and at each the differences to both neighbours along
  // each axis: forward differences alone would become backward ones in a
  // flipped copy and pair other voxels.
  const BoxLattice lat = BoxLattice::fit(slo_, shi_, kNoisePoints);
  const int64_t cap = kNoisePoints;
  int64_t ns = 0;
  float* vals = scratch_;
  lat.for_each([&](int64_t i, int64_t j, int64_t k) {
    const double x = vol.at(i, j, k);
    if (!std::isfinite(x) || ns >= cap) return;  // non-finite voxels take no part in the statistics
    vals[ns++] = float(x);
  });
  if (ns == 0) {
    p_lo_ = p_hi_ = c_lo_ = c_hi_ = 0;
    fence_lo_ = -INFINITY;
    fence_hi_ = INFINITY;
    sigma_n_ = sigma_d_ = 0;
    gain_ = 1;
    lag_ = 1;
    over_[0] = over_[1] = over_[2] = false;
    return;
  }
  p_lo_ = nth_of(vals, ns, int64_t(std::floor(0.01 * double(ns - 1))));
  p_hi_ = nth_of(vals, ns, int64_t(std::ceil(0.99 * double(ns - 1))));
  // The contrast range: the same percentiles over the values inside Tukey's
  // far-out fences, Q1 - 3 IQR .. Q3 + 3 IQR. The fences keep every class
  // that is a neighbour in grey level of the box's bulk and leave out the
  // remote ones (air at -1000 HU beside soft tissue of 0-60 HU), so that the
  // scale does not jump with a few voxels of gas or lung in the box. A box
  // whose IQR is 0 (one level holds half of it) keeps every value: the
  // fences are undefined there. (The model uses the range only when the
  // object's own level lies within the fences: intensity_model.h.)
  const double q1 = nth_of(vals, ns, int64_t(std::floor(0.25 * double(ns - 1))));
  const double q3 = nth_of(vals, ns, int64_t(std::ceil(0.75 * double(ns - 1))));
  const double iqr = q3 - q1;
  c_lo_ = p_lo_;
  c_hi_ = p_hi_;
  fence_lo_ = -INFINITY;
  fence_hi_ = INFINITY;
  if (iqr > 0) {
    const double flo = q1 - kFarOutIqr * iqr, fhi = q3 + kFarOutIqr * iqr;
    fence_lo_ = flo;
    fence_hi_ = fhi;
    int64_t nk = 0;
    for (int64_t i = 0; i < ns; ++i)
      if (vals[i] >= flo && vals[i] <= fhi) vals[nk++] = vals[i];
    if (nk > 0) {
      c_lo_ = nth_of(vals, nk, int64_t(std::floor(0.01 * double(nk - 1))));
      c_hi_ = nth_of(vals, nk, int64_t(std::ceil(0.99 * double(nk - 1))));
    }
  }
  noise_scales(vol, lat);
}

// sigma_n_ (lag 1) and sigma_d_, the noise at the lag where it has
// decorrelated (smoothing.h). At lag L along axis a, over the lattice voxels
// x_i (their neighbours at +-L inside the statistics box):
//   s_a(L)   = 1.4826 median|x_{i+-L} - x_i| / sqrt(2)       (at L = 1: sigma_n_, the smallest over the axes)
//   rho_a(L) = (m_A^2 - m_B^2) / (m_A^2 + m_B^2),  m_A = median|x_{i+L} - x_{i-L}|,
//              m_B = median|x_{i+L} - 2 x_i + x_{i-L}|
// rho_a(L) is Gnanadesikan and Kettenring's robust correlation of the two
// increments x_{i+L} - x_i and x_i - x_{i-L} (their sum and difference are
// the lag-2L and second differences). An axis oversamples the noise when
// rho_a(1) >= kOversampledRho. The axes that do are read together at the
// first lag where the median of their rho_a is <= 0 (a grid resampled
// finer along several axes decorrelates at one lag, the resampling's), each
// at its s_a there; the others at lag 1; sigma_d_ is the smallest of these
// scales, as sigma_n_ is of the lag-1 ones (an axis across an edge reads
// more than the noise, never less). No axis oversampled, or no lag within
// kMaxNoiseLag where they decorrelate: sigma_n_. A scan whose thick slices
// were reformatted into thin ones oversamples along one axis only, and its
// lag-1 scale along that axis, the smallest, reads a fraction of the noise.
void SmoothedRoi::noise_scales(const VolumeView& vol, const BoxLattice& lat) {
  const int64_t cap = kNoisePoints;
  float* cd = scratch_;            // both sides' |x_{i+-L} - x_i|: 2 cap
  float* ad = scratch_ + 2 * cap;  // |x_{i+L} - x_{i-L}|: cap
  float* bd = scratch_ + 3 * cap;  // |x_{i+L} - 2 x_i + x_{i-L}|: cap
  // rho from the n pairs' |sum| (m_A) and |difference| (m_B) of the two
  // increments; false: too few pairs.
  auto correlation = [](float* sums, float* diffs, int64_t n, double* rho) {
    if (n < 16) return false;
    const double ma = nth_of(sums, n, n / 2), mb = nth_of(diffs, n, n / 2);
    const double den = ma * ma + mb * mb;
    *rho = den > 0 ? (ma * ma - mb * mb) / den : -0.5;  // a flat box: nothing to decorrelate
    return true;
  };
  // s_a(L) (< 0: too few pairs) and rho_a(L) (false: too few pairs) along axis a.
  auto scales = [&](int a, int64_t L, double* sa, double* rho) {
    int64_t nc = 0, nab = 0;
    lat.for_each([&](int64_t i, int64_t j, int64_t k) {
      const double x = vol.at(i, j, k);
      if (!std::isfinite(x)) return;
      int64_t q[3] = {i, j, k}, r[3] = {i, j, k};
      q[a] += L;
      r[a] -= L;
      const bool hq = q[a] < shi_[a], hr = r[a] >= slo_[a];
      const double xq = hq ? vol.at(q[0], q[1], q[2]) : 0, xr = hr ? vol.at(r[0], r[1], r[2]) : 0;
      const bool fq = hq && std::isfinite(xq), fr = hr && std::isfinite(xr);
      if (fq) cd[nc++] = float(std::fabs(xq - x));
      if (fr) cd[nc++] = float(std::fabs(xr - x));
      if (fq && fr) {
        ad[nab] = float(std::fabs(xq - xr));
        bd[nab] = float(std::fabs(xq + xr - 2 * x));
        ++nab;
      }
    });
    *sa = nc >= 16 ? 1.4826 * double(nth_of(cd, nc, nc / 2)) / std::sqrt(2.0) : -1;
    return correlation(ad, bd, nab, rho);
  };
  // rho_a(1) about the voxels one step either side of the lattice's along
  // a (both sides: the set is its own mirror image, box_lattice.h). A
  // lattice whose step is a multiple of the resampling factor may hold only
  // voxels at the coarse samples' own positions, where the increments on
  // either side are independent (rho -1/2, white noise to all appearances)
  // although every voxel between is an interpolation; beside them the
  // increments are of one interpolation segment (rho +1).
  auto rho_beside = [&](int a, double* rho) {
    float* sd = scratch_;            // |x_{i+1} - x_{i-1}|: 2 cap
    float* dd = scratch_ + 2 * cap;  // |x_{i+1} - 2 x_i + x_{i-1}|: 2 cap
    int64_t n = 0;
    for (int side = -1; side <= 1; side += 2)
      lat.for_each([&](int64_t i, int64_t j, int64_t k) {
        int64_t c[3] = {i, j, k};
        c[a] += side;
        if (c[a] - 1 < slo_[a] || c[a] + 1 >= shi_[a]) return;
        int64_t q[3] = {c[0], c[1], c[2]}, r[3] = {c[0], c[1], c[2]};
        ++q[a];
        --r[a];
        const double x = vol.at(c[0], c[1], c[2]), xq = vol.at(q[0], q[1], q[2]), xr = vol.at(r[0], r[1], r[2]);
        if (!std::isfinite(x) || !std::isfinite(xq) || !std::isfinite(xr)) return;
        sd[n] = float(std::fabs(xq - xr));
        dd[n] = float(std::fabs(xq + xr - 2 * x));
        ++n;
      });
    return correlation(sd, dd, n, rho);
  };
  auto smaller = [](double a, double b) { return a < 0 || (b >= 0 && b < a) ? b : a; };
  bool over[3] = {false, false, false};
  int n_over = 0;
  double rest = -1;  // the smallest lag-1 scale of the axes that sample the noise
  sigma_n_ = -1;
  for (int a = 0; a < 3; ++a) {
    double sa, rho, rho_b;
    over[a] = scales(a, 1, &sa, &rho) && rho >= kOversampledRho && sa >= 0;
    if (!over[a] && sa >= 0 && lat.step > 1 && rho_beside(a, &rho_b)) over[a] = rho_b >= kOversampledRho;
    n_over += over[a];
    sigma_n_ = smaller(sigma_n_, sa);
    if (!over[a]) rest = smaller(rest, sa);
  }
  if (sigma_n_ < 0) sigma_n_ = 0;
  sigma_d_ = sigma_n_;
  gain_ = 1;
  lag_ = 1;
  over_[0] = over_[1] = over_[2] = false;
  if (n_over == 0) return;  // the lag-1 differences see the noise
  for (int64_t L = 2; L <= kMaxNoiseLag; ++L) {
    double rho[3], best = -1;
    int nr = 0;
    for (int a = 0; a < 3; ++a) {
      if (!over[a]) continue;
      double sa, r;
      if (scales(a, L, &sa, &r)) rho[nr++] = r;
      best = smaller(best, sa);
    }
    if (best < 0 || nr == 0) return;  // the box holds no more pairs at this lag
    for (int u = 1; u < nr; ++u)  // at most three: insertion sort
      for (int v = u; v > 0 && rho[v] < rho[v - 1]; --v) std::swap(rho[v], rho[v - 1]);
    const double med = nr % 2 ? rho[nr / 2] : 0.5 * (rho[nr / 2 - 1] + rho[nr / 2]);
    if (med <= 0) {
      sigma_d_ = smaller(best, rest);
      // Linear interpolation by L keeps (2 L^2 + 1) / (3 L^2) of the
      // acquired variance on average over the L phases along an axis (the
      // weights (1 - f, f) at f = k / L); the oversampled axes multiply.
      const double Ld = double(L), kept = (2 * Ld * Ld + 1) / (3 * Ld * Ld);
      gain_ = std::pow(kept, -0.5 * double(n_over));
      lag_ = L;
      for (int a = 0; a < 3; ++a) over_[a] = over[a];
      return;
    }
  }
}

namespace {

void diffuse_sse(float* buf, float* scratch, int64_t E0, int64_t E1, int64_t E2, const float w[3], const float ik[3]) {
  diffuse_sweep<V4, V4i, 4>(buf, scratch, E0, E1, E2, w, ik);
}

}  // namespace

void SmoothedRoi::diffuse(uint32_t iterations) {
  const int64_t E0 = ghi_[ax_[0]] - glo_[ax_[0]];
  const int64_t E1 = ghi_[ax_[1]] - glo_[ax_[1]];
  const int64_t E2 = ghi_[ax_[2]] - glo_[ax_[2]];
  float w[3], ik[3];
  for (int s = 0; s < 3; ++s) {
    const double h = h_[ax_[s]];
    w[s] = float(dt_ / (h * h));                       // dt / h_a^2
    ik[s] = float(1.0 / (h * h * kappa_ * kappa_));    // (1 / (h_a kappa))^2, eq. 5.2.2
  }
  // Same arithmetic in every kernel (bit-identical); the engine's choice.
  const Isa k = cpu_.kernel(KernelFamily::smoothing);
  (void)k;  // only the x86 kernels read it
  for (uint32_t it = 0; it < iterations; ++it) {
#if FFSEG_X86
    if (k == Isa::avx512) {
      diffuse_sweep_avx512(buf_, scratch_, E0, E1, E2, w, ik);
      continue;
    }
    if (k == Isa::avx2) {
      diffuse_sweep_avx2(buf_, scratch_, E0, E1, E2, w, ik);
      continue;
    }
#endif
    diffuse_sse(buf_, scratch_, E0, E1, E2, w, ik);
  }
}

bool SmoothedRoi::contains(const int64_t lo[3], const int64_t hi[3]) const {
  if (!valid_) return false;
  for (int a = 0; a < 3; ++a) {
    const int64_t l = std::max<int64_t>(0, std::min<int64_t>(lo[a], grid_[a]));
    const int64_t h = std::max<int64_t>(0, std::min<int64_t>(hi[a], grid_[a]));
    if (l >= h) continue;  // nothing of it on the grid along this axis
    if (l < lo_[a] || h > hi_[a]) return false;
  }
  return true;
}

double SmoothedRoi::sample_linear(const double w[3]) const {
  double p[3];
  world_to_index(w, p);
  return sample_index(p);
}

void SmoothedRoi::world_to_index(const double w[3], double p[3]) const { affine_point(Ainv_, w, p); }

void SmoothedRoi::index_to_world(const double p[3], double w[3]) const { affine_point(A_, p, w); }

void SmoothedRoi::world_dir_to_index(const double w[3], double p[3]) const { affine_direction(Ainv_, w, p); }

namespace {

void finish_box(const VolumeView& vol, const double pmin[3], const double pmax[3], double grow_mm, int64_t lo[3],
                int64_t hi[3]) {
  const double* Ai = vol.inverse();
  const int64_t* D = vol.dims();
  for (int a = 0; a < 3; ++a) {
    const double row = std::sqrt(Ai[4 * a] * Ai[4 * a] + Ai[4 * a + 1] * Ai[4 * a + 1] + Ai[4 * a + 2] * Ai[4 * a + 2]);
    const double g = (grow_mm > 0 ? grow_mm : 0) * row;
    if (!(pmin[a] <= pmax[a])) {  // no finite point
      lo[a] = 0;
      hi[a] = 0;
      continue;
    }
    lo[a] = clamp_to_index(std::floor(pmin[a] - g), -1, D[a] + 1);
    hi[a] = clamp_to_index(std::ceil(pmax[a] + g) + 1, -1, D[a] + 1);
  }
}

}  // namespace

void roi_box_for_points(const VolumeView& vol, const double* x, uint32_t n, double grow_mm, int64_t lo[3],
                        int64_t hi[3]) {
  double pmin[3] = {INFINITY, INFINITY, INFINITY}, pmax[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (uint32_t v = 0; v < n; ++v) {
    const double* w = x + 3 * size_t(v);
    if (!(std::isfinite(w[0]) && std::isfinite(w[1]) && std::isfinite(w[2]))) continue;
    double p[3];
    vol.world_to_index(w, p);
    for (int a = 0; a < 3; ++a) {
      pmin[a] = p[a] < pmin[a] ? p[a] : pmin[a];
      pmax[a] = p[a] > pmax[a] ? p[a] : pmax[a];
    }
  }
  finish_box(vol, pmin, pmax, grow_mm, lo, hi);
}

void roi_box_for_ball(const VolumeView& vol, const double c[3], double r, int64_t lo[3], int64_t hi[3]) {
  double p[3];
  vol.world_to_index(c, p);
  finish_box(vol, p, p, r, lo, hi);
}

}  // namespace ffseg
