// Perona-Malik anisotropic diffusion (thesis 5.2.1, eq. 5.2.1-5.2.2; Perona &
// Malik 1990) on a cropped region of the volume, held in the workspace.
//
//   dI/dt = div(c(|grad I|) grad I),   c(s) = 1 / (1 + (s / kappa)^2)
//
// Discretisation (PM90 eq. 9, with the real voxel spacing h_a in mm): per face
// between neighbours along axis a, the gradient magnitude is approximated by
// the directional difference |dI| / h_a, and
//
//   I' = I + dt * sum_faces c(|dI| / h_a) * dI / h_a^2.
//
// Time step: dt = 0.75 / (2 * sum_a 1/h_a^2) mm^2. Every update is a convex
// combination of a voxel and its six neighbours as long as
// dt <= 1 / (2 sum_a 1/h_a^2) (c <= 1), so the scheme obeys the maximum
// principle (smoothed values stay inside the crop's raw range) and is stable
// for any number of iterations; the factor 0.75 keeps the centre weight >= 1/4
// so no checkerboard mode survives (for unit spacing dt = 0.0625, ITK's default).
// On 0.7 x 0.7 x 5 mm CT, dt = 0.091 mm^2: diffusion across 5 mm slices is
// physically slow, exactly as the equation in millimetres says.
//
// Contrast parameter kappa (intensity per mm; c = 1/2 where |grad I| = kappa).
// Default (kappa <= 0): kappa = 2 sigma_n / h_min, with sigma_n a robust noise
// estimate of the raw data in the requested box: sigma_a = 1.4826 *
// median|I(x +- e_a) - I(x)| / sqrt(2) per axis over at most kNoisePoints voxels
// x of the statistics box, a lattice that a flipped or permuted copy of the
// volume chooses the same anatomy of (box_lattice.h; so are its p1..p99),
// sigma_n = the smallest of the three (structure only inflates an axis'
// estimate). That is Black et al. 1998's robust scale sigma_e = 1.4826 MAD of
// the directional derivatives, with kappa = sqrt(2) sigma_e (the Lorentzian's
// outlier threshold): pure noise keeps c ~ 2/3 and diffuses, a step of a few
// sigma_n across one voxel gets c << 1 and is kept. sigma_n is floored at
// 1e-3 of the crop's robust range (p1..p99) so noise-free data still diffuses a little.
//
// Boundary: the crop is computed over the requested box grown by one voxel per
// iteration on each side (clipped to the grid), with zero flux at the grown
// box's faces. An explicit step reads only the six neighbours, so inside the
// requested box the result equals smoothing the whole volume (zero flux at the
// grid's faces) - exactly, for a given kappa.
//
// Memory: max_voxels floats for the region, plus 2 planes of the region (and 3
// zero floats around them, read by the vector kernels' edge lanes) for the
// in-place sweep (the region is stored with its longest axis slowest, so a plane
// holds at most max_voxels^(2/3) voxels), at least 7 * kNoisePoints floats
// (shared with the noise estimate, which uses four per voxel: both sides'
// differences along an axis, and the two combined ones of the correlation).
//
// Values beyond the stored region: sample_index() clamps to the nearest stored
// voxel; inside_index() tells whether a point lies in the region's voxel box
// (the correspondence search treats points outside as background).
#pragma once
#include <cstddef>
#include <cstdint>
#include <cmath>

#include "arena.h"
#include "box_lattice.h"
#include "cpu_dispatch.h"
#include "crop_pool.h"
#include "volume.h"

namespace ffseg {

struct SmoothingSettings {
  uint32_t iterations = 5;  // explicit steps of dt each (also the crop margin in voxels)
  double kappa = 0;         // intensity per mm; <= 0: derived from the noise estimate
  // false: with kappa > 0 on an integer volume, skip the statistics of the
  // requested box (noise_sigma(), robust_low/high() then read 0); the
  // smoothed values do not depend on them there.
  bool statistics = true;
  // The box the statistics are taken over (clipped to the requested box);
  // nullptr: the requested box. The engine passes a box of a fixed size
  // around the seed's centre, so the seed's size does not change them
  // (intensity_model.h, variance floor).
  const int64_t* stats_lo = nullptr;
  const int64_t* stats_hi = nullptr;
  // A crop carved in a shared room (carve_in()) may take more than its own
  // max_voxels when the room has it free (the engine's crop of what the mesh
  // needs; its crop with slack keeps to its own room, so that one organ's
  // slack never crowds another organ out).
  bool share_room = false;
};

enum class RoiStatus : int {
  ok = 0,
  empty,       // the box does not meet the grid
  too_large,   // needed_voxels() > max_voxels (engine: FFSEG_ERR_ROI_TOO_LARGE)
  not_carved,  // carve() was not run over real memory, or max_voxels was 0
  bad_volume,  // the view is not valid
};

class SmoothedRoi {
 public:
  static constexpr uint32_t kNoisePoints = 4681;  // 7 floats each (four used): the 32768 of the scratch's floor

  // Floats per sweep plane for a region of at most max_voxels voxels.
  static int64_t plane_capacity(int64_t max_voxels);
  // Carves room for a region of at most max_voxels voxels (see the header note).
  // cpu: the engine's kernels; the diffusion sweep runs cpu's smoothing kernel
  // (4, 8 or 16 lanes, the scalar code's operations in its order without FMA,
  // so every kernel gives the same crop).
  void carve(Arena& a, int64_t max_voxels, const CpuDispatch& cpu);
  // The same with the region's floats from a room shared with other crops
  // (crop_pool.h), as its owner `slot`: max_voxels is its own room (what it
  // may take without SmoothingSettings::share_room), scratch the sweep's and
  // the noise estimate's floats (scratch_floats(room.capacity()) of them),
  // shared by every crop of the room, which compute() one at a time.
  void carve_in(CropPool& room, uint32_t slot, int64_t max_voxels, float* scratch, const CpuDispatch& cpu);
  static int64_t scratch_floats(int64_t max_voxels);

  // Smooths the region [lo, hi) (index space, clipped to the grid, grown by
  // s.iterations voxels per side). On failure the crop is invalid, msg (if
  // given) says why; for too_large it names the voxels needed.
  RoiStatus compute(const VolumeView& vol, const int64_t lo[3], const int64_t hi[3],
                    const SmoothingSettings& s, char* msg = nullptr, size_t msg_len = 0);

  bool valid() const { return valid_; }
  void invalidate() { valid_ = false; }
  // True when the valid crop covers [lo, hi) clipped to the grid, with its
  // exact (full-volume-equal) values.
  bool contains(const int64_t lo[3], const int64_t hi[3]) const;

  // The box of the statistics (clipped to the requested one).
  const int64_t* stats_lo() const { return slo_; }
  const int64_t* stats_hi() const { return shi_; }
  // The requested box (clipped) and the stored, grown box [data_lo, data_hi).
  const int64_t* lo() const { return lo_; }
  const int64_t* hi() const { return hi_; }
  const int64_t* data_lo() const { return glo_; }
  const int64_t* data_hi() const { return ghi_; }
  int64_t max_voxels() const { return max_voxels_; }
  int64_t needed_voxels() const { return needed_; }  // after compute (also on too_large)

  // Smoothed value of voxel (i, j, k); it must lie inside [data_lo, data_hi).
  float at(int64_t i, int64_t j, int64_t k) const {
    return buf_[(i - glo_[0]) * st_[0] + (j - glo_[1]) * st_[1] + (k - glo_[2]) * st_[2]];
  }
  // True when index-space point p lies in the stored region's voxel box
  // [data_lo - 0.5, data_hi - 0.5].
  bool inside_index(const double p[3]) const {
    for (int a = 0; a < 3; ++a)
      if (!(p[a] >= in_lo_[a] && p[a] <= in_hi_[a])) return false;
    return true;
  }
  // Trilinear value at index-space point p, coordinates clamped to the stored
  // voxel centres (nearest crop voxel beyond the region). Inline: the
  // correspondence search calls it for every sample along every normal.
  double sample_index(const double p[3]) const {
    int64_t off = 0;
    double f[3];
    for (int a = 0; a < 3; ++a) {
      double x = p[a];
      const double l = centre_lo_[a], h = centre_hi_[a];
      if (!(x > l)) x = l;  // NaN too
      if (x > h) x = h;
      // x >= data_lo >= 0 here, so truncation is floor (and cheaper than it).
      int64_t q = int64_t(x);
      const double fl = double(q);
      f[a] = x - fl;
      if (q >= ghi_[a] - 1) {
        q = ghi_[a] - 1;
        f[a] = 0;
      }
      off += (q - glo_[a]) * st_[a];
    }
    // Corner c = (dx, dy, dz) = bits 0, 1, 2 of c; weight (wx * wy) * wz. A
    // corner of weight 0 is skipped (it may lie beyond the stored region).
    const double wx[2] = {1 - f[0], f[0]}, wy[2] = {1 - f[1], f[1]}, wz[2] = {1 - f[2], f[2]};
    const double wxy[4] = {wx[0] * wy[0], wx[1] * wy[0], wx[0] * wy[1], wx[1] * wy[1]};
    const int64_t co[4] = {0, st_[0], st_[1], st_[0] + st_[1]};
    const float* b = buf_ + off;
    double acc = 0;
    for (int dz = 0; dz < 2; ++dz) {
      const float* bz = b + (dz ? st_[2] : 0);
      for (int c = 0; c < 4; ++c) {
        const double wgt = wxy[c] * wz[dz];
        if (wgt == 0) continue;
        acc += wgt * bz[co[c]];
      }
    }
    return acc;
  }
  // Same at a world point (mm).
  double sample_linear(const double w[3]) const;

  void world_to_index(const double w[3], double p[3]) const;
  void index_to_world(const double p[3], double w[3]) const;
  void world_dir_to_index(const double w[3], double p[3]) const;
  const double* spacing() const { return h_; }

  // Statistics of the last compute (raw data in the requested box).
  double noise_sigma() const { return sigma_n_; }
  // The noise at the lag where it has decorrelated: noise_sigma() unless the
  // grid oversamples the box's noise along some axis. A volume resampled onto
  // a finer grid than it was acquired on (the 1 mm CT made from 3 mm by
  // trilinear interpolation; thick slices reformatted into thin ones, along
  // one axis), or shaped by a smooth reconstruction kernel, holds noise that
  // is smooth at one voxel: its lag-1 differences read a fraction of its
  // spread (2 HU for the 1 mm CT liver, whose 3 mm scan reads 10.5). The
  // increments' robust correlation at lag 1 (smoothing.cpp) tells, axis by
  // axis: for a variogram gamma(L) ~ L^alpha it is 2^(alpha - 1) - 1, -1/2
  // for white noise (alpha 0), 0 for a random walk, 1 for a field
  // differentiable at the voxel scale (alpha 2). The axes where it is at
  // least kOversampledRho (alpha >= 1.8: a smooth field; the 1 mm CT's boxes
  // read 0.80-0.98 as a median over the axes, Colin27's template 0.00-0.60,
  // the 3 mm CT's -0.54..-0.13) are read at the first lag where their
  // increments are no longer positively correlated (rho <= 0, median over
  // them), up to kMaxNoiseLag; the other axes at lag 1 (an axis is also
  // read beside the statistics lattice's voxels, which may all lie on the
  // coarse samples' own positions: smoothing.cpp); the estimate is the
  // smallest of these scales (an axis across an edge reads more than the
  // noise). No axis oversampled, or none decorrelates: noise_sigma(). Read
  // by the intensity model's variance floor only (capped there by the
  // sphere's own spread); the diffusion's kappa keeps noise_sigma().
  double decorrelated_noise_sigma() const { return sigma_d_; }
  // The noise as acquired over the noise as this grid samples it, where the
  // grid oversamples (decorrelated_noise_sigma() came from a lag L > 1):
  // a value interpolated between acquired samples averages their noise, so
  // the resampled grid's voxels hold less of it than the scanner's did
  // (trilinearly from 3 mm to 1 mm: 0.70 of the variance per axis, a third
  // of it over three axes). With linear interpolation by L along each of
  // the n oversampled axes the gain is ((2 L^2 + 1) / (3 L^2))^(-n/2),
  // with L the lag at which the increments decorrelated (at most the
  // resampling factor: 3 for 3 mm made 1 mm along all axes, gain 1.69; 2
  // along z alone, 1.15: then a little low, on the narrow side). 1 when no
  // axis oversamples. Read by the intensity model's floor (intensity_model.h,
  // capped there by the sphere's spread as acquired): the organ's smoothed
  // values vary as the acquired noise does, and a resampled grid must not
  // narrow the model (the 1 mm CT's liver: 0.750 -> 0.897, BENCHMARKS
  // section 12).
  double acquisition_gain() const { return gain_; }
  // The lag acquisition_gain() came from (1 when no axis oversamples) and
  // the axes that oversample: the resampling's phases (intensity_model.cpp).
  int64_t noise_lag() const { return lag_; }
  bool oversampled(int a) const { return over_[a]; }
  // How many of the grid's finest spacings the scan's finest acquired
  // spacing spans: min_a h_a L_a / min_a h_a, L_a the lag on the oversampled
  // axes and 1 on the others (3 for the 1 mm CT made from 3 mm, and for 3 x 3
  // x 1 made from 3 x 3 x 3; 1 on a scan's own grid). An edge is as wide in
  // mm as the acquisition made it, so what is read "a few samples beyond"
  // it must be counted in acquired samples (intensity_search.h's
  // partial-volume level).
  double acquisition_scale() const {
    double grid = h_[0], acquired = h_[0] * (over_[0] ? double(lag_) : 1.0);
    for (int a = 1; a < 3; ++a) {
      grid = h_[a] < grid ? h_[a] : grid;
      const double ha = h_[a] * (over_[a] ? double(lag_) : 1.0);
      acquired = ha < acquired ? ha : acquired;
    }
    return grid > 0 ? acquired / grid : 1.0;
  }
  static constexpr double kOversampledRho = 0.75;
  static constexpr int64_t kMaxNoiseLag = 16;
  double kappa() const { return kappa_; }
  double time_step() const { return dt_; }
  double robust_low() const { return p_lo_; }    // 1st percentile
  double robust_high() const { return p_hi_; }   // 99th percentile
  // The 1st and 99th percentiles of the values within Tukey's far-out fences
  // (smoothing.cpp): the box's contrast without remote classes (the
  // intensity model's variance floor).
  double contrast_low() const { return c_lo_; }
  double contrast_high() const { return c_hi_; }
  // The fences themselves (+-inf when the IQR is 0).
  double fence_low() const { return fence_lo_; }
  double fence_high() const { return fence_hi_; }
  static constexpr double kFarOutIqr = 3;  // Tukey's "far out": 3 IQR beyond the quartiles
  double value_min() const { return vmin_; }     // raw range of the stored region
  double value_max() const { return vmax_; }

 private:
  void estimate_noise(const VolumeView& vol);
  void noise_scales(const VolumeView& vol, const BoxLattice& lat);
  void diffuse(uint32_t iterations);
  // Copies the stored region of an integer volume (typed rows); false: the
  // generic per-voxel copy must do it (floats, or extreme rescale factors).
  bool copy_integer(const VolumeView& vol, double* vmin, double* vmax);
  static bool integer_copy_applies(const VolumeView& vol);

  float* buf_ = nullptr;
  float* scratch_ = nullptr;
  CropPool* room_ = nullptr;  // carve_in(): buf_ is a span of this room
  uint32_t slot_ = 0;
  int64_t max_voxels_ = 0;
  int64_t plane_cap_ = 0;
  int64_t scratch_len_ = 0;
  bool valid_ = false;
  int64_t lo_[3] = {0, 0, 0}, hi_[3] = {0, 0, 0};
  int64_t glo_[3] = {0, 0, 0}, ghi_[3] = {0, 0, 0};
  // The stored box's bounds as the samplers read them, converted once per
  // compute() instead of at every sample (the same doubles): the voxel box
  // [glo_ - 0.5, ghi_ - 0.5] and the first and last voxel centres.
  double in_lo_[3] = {0, 0, 0}, in_hi_[3] = {0, 0, 0};
  double centre_lo_[3] = {0, 0, 0}, centre_hi_[3] = {0, 0, 0};
  int64_t grid_[3] = {0, 0, 0};
  int64_t st_[3] = {0, 0, 0};  // buffer stride of each index axis
  int64_t ext_[3] = {0, 0, 0}; // stored region's extent per index axis
  CpuDispatch cpu_;
  int ax_[3] = {0, 1, 2};      // storage order, fastest first
  int64_t needed_ = 0;
  double A_[12] = {}, Ainv_[12] = {};
  double h_[3] = {1, 1, 1};
  double sigma_n_ = 0, sigma_d_ = 0, gain_ = 1, kappa_ = 0, dt_ = 0;
  int64_t lag_ = 1;
  bool over_[3] = {false, false, false};
  double p_lo_ = 0, p_hi_ = 0, c_lo_ = 0, c_hi_ = 0, fence_lo_ = 0, fence_hi_ = 0, vmin_ = 0, vmax_ = 0;
  int64_t slo_[3] = {0, 0, 0}, shi_[3] = {0, 0, 0};
};

// Index box [lo, hi) covering n points (3n doubles, mm) grown by grow_mm in
// every direction (exact for oblique affines: a ball of radius g spans
// g * |row a of the inverse affine| along index axis a). Not clipped to the grid
// but clamped to [-1, dims + 1]; non-finite points are skipped.
void roi_box_for_points(const VolumeView& vol, const double* x, uint32_t n, double grow_mm, int64_t lo[3],
                        int64_t hi[3]);
// Index box of a ball (centre c, radius r, mm), same conventions.
void roi_box_for_ball(const VolumeView& vol, const double c[3], double r, int64_t lo[3], int64_t hi[3]);

}  // namespace ffseg
