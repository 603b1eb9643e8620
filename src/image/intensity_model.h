// Intensity statistics of the target organ (thesis 5.2.2): a 1-D Gaussian
// mixture g(x) = sum_i a_i f_i(x) (eq. 5.2.3) of the smoothed voxels inside the
// initial sphere. The number of components comes from adaptive binning
// (Algorithm 2, [LL03]: radius R, separation S, minimum count N_m); the
// parameters from EM (eq. 5.2.4-5.2.7) started at the bins.
//
// What g means here. The thesis thresholds the mixture density, h = [g(x) >= Gamma]
// (eq. 5.3.2), but a density has units of 1/intensity, so a fixed Gamma would
// mean different things on u8 MR and HU CT. ffseg divides by the mixture's peak:
//   g(x) = sum_i a_i f_i(x) / max_y sum_i a_i f_i(y)   in [0, 1],
// the thesis' g up to a constant, so thresholding it is eq. 5.3.2 with a
// dimensionless Gamma. For one Gaussian g = exp(-z^2 / 2): Gamma = 0.05 keeps
// |x - mu| < 2.45 sigma. A minor component of weight a sits at about a relative
// to the main one, so Gamma also sets how rare a sub-class may be and still count.
//
// Variance floor (why the sphere's spread is not taken at face value): a small
// sphere sees one spot of the organ; the organ as a whole also varies with
// position (bias field, partial volume, tissue texture), and on near noise-free
// data (Colin27: 1-3 grey levels in a sphere, 7-22 over the structure) the
// sphere's own variance would stop the mesh almost at once. Every component's
// variance is floored at
//   sigma_floor^2 = sigma_n^2 + (rho * D)^2
// with sigma_n the crop's robust noise estimate (SmoothedRoi::noise_sigma; on a
// grid that oversamples its noise, a volume resampled finer than it was
// acquired, the estimate at the lag where the noise has decorrelated,
// SmoothedRoi::decorrelated_noise_sigma, capped by the sphere's robust spread
// in the raw volume: the noise is part of that spread, and a template's
// anatomy read as noise must not widen the floor past it. A resampled
// grid's interpolated voxels hold less noise than the scanner gave, so both
// are read at the acquisition's scale: the decorrelated estimate times
// SmoothedRoi::acquisition_gain, and the sphere's spread at the acquired
// samples' own positions, the largest over the resampling's phases (index
// mod the noise's lag along each oversampled axis; intensity_model.cpp,
// acquired_spread). Noise is whole at one phase and averaged at the others;
// anatomy reads the same at all, so a template's spread is not widened
// (Colin27 at 0.5 mm) while a CT's reaches its scan's: the 1 mm liver's
// sphere reads 6.7 HU over all its voxels and 11.1 at one phase, as the
// 3 mm scan does), D the
// crop's robust intensity range p99 - p1 (the contrast scale of the scene)
// taken within Tukey's far-out fences (Q1 - 3 IQR .. Q3 + 3 IQR of the box):
// a CT box that holds a few percent of air or lung has p1 at -1000 HU, and
// its D of 1,000 HU instead of the soft tissues' 150 made the floor 44 HU, so
// wide that the gallbladder (3 HU) took the liver and fat around it (issue
// 30: Dice 0.06, 756 ml of 35). When the sphere's median lies outside the
// fences (a box held by one flat level other than the object, e.g. a small
// structure in a noise-free background) they say nothing about what is remote
// from the object, and D is the whole p1..p99 range. Both are taken over the
// crop's statistics box (the engine: the search range
// around the seed's centre, not the seed's radius plus it, so that the seed's
// size does not decide which tissues set the scale), and
// rho = sigma_floor_fraction (default 0.04): the tolerated within-organ
// variation is a fixed fraction of the scene's contrast, plus the noise. With
// Gamma = 0.2 (|x - mu| < 1.79 sigma) an object then spans about +-1.79 * 0.04
// = +-7% of the box's range around its mean beyond the noise (rho chosen on
// the right-hemisphere Colin27 structures, issue 19): a neighbour must differ
// by more than that (T1 brain:
// grey vs white matter is about 40% of a crop's range; CT: liver vs fat 160 HU
// of a 230-500 HU range). rho = 0 takes the sphere at face value. The floor is
// applied inside EM (a constrained maximum-likelihood fit), so a component
// never narrows below it. rho is the one calibration knob of the model.
//
// Competing classes of the scene (fit(), scene_competitors, default on). The
// object model alone says how far a value is from the sphere's intensities, not
// whether some other tissue explains it better. fit() therefore also fits the
// same mixture (Algorithm 2 + EM, the same floor) to the crop's statistics box
// (at most kSceneSamples voxels, uniform stride): the scene's tissue classes.
// The scene components that claim an object component's mean (highest weighted
// density there) and explain it (their own peak-normalised density there is
// at least Gamma: the mean would be accepted by that class) are the object's
// own classes, of total scene weight a_o; the others compete. An object
// class no scene class explains was too rare in the box for binning to give
// it a bin of its own (a tube 8 mm across in a box 40 mm wide: 3% of it;
// the one background class then claimed it, became "own" and nothing
// competed, so the partial-volume level of intensity_search.h had no rival
// and the grey boundary stayed half a voxel inside). Its scene weight is
// then at most binning's minimum share N_m / n, and a_o is taken as that. A
// competitor more probable than the object at one of the object's own class
// means is counted as the object's own as well: the box does not tell them
// apart, and as a rival it would make the object refuse its own sphere's
// grey level (the CT's portal vein at 3 mm: a broad class of the box, -34 +-
// 40 HU, beat the vein's 41 +- 22 at 41, and no vertex found a boundary). A value is then object only if, besides g >= Gamma,
//   a_o f_obj(v) >= sum_competitors a_c f_c(v),
// the Bayes decision between the object (its class-conditional density taken
// from the sphere) and the scene's other classes; g(v) reads 0 where it fails.
// This lets Gamma be lower (a wider object interval where no other class of the
// scene competes, e.g. the caudate between CSF and white matter) while a
// neighbouring class still cuts the interval at the densities' crossing.
// Colin27 (issue #4): with Gamma chosen on the right-hemisphere structures only
// (0.2, engine default), left structures held out. Threshold-free: no new
// constant beyond the sample cap.
//
// Trimming the sphere (fit(), trim_sds, default 2.5). A seed sphere placed by
// hand, or moved by a millimetre, often clips a neighbour: a few voxels of
// white matter or CSF at its rim. Binning's N_m (5% of the samples) keeps a
// rim class of 5% or more, and EM then gives the object a second class at the
// neighbour's grey level, so the mesh leaks into that neighbour from one seed
// and not from the next (Colin27, issue 19: seed stability). fit() therefore
// keeps only the sphere samples within trim_sds robust standard deviations of
// their median, the robust sd max(IQR / 1.349, sigma_floor) (the floor, so
// that a near-constant sphere of 1-3 grey levels is not cut to one level).
// A sub-class of the organ holding a quarter of the sphere or more moves the
// quartiles and stays; a rim of a few percent, far from the median, goes.
// Chosen on the right-hemisphere Colin27 structures: 1.5-3 all give the same
// stability (0.868-0.874 mean pairwise Dice against 0.842 without). fit_samples
// takes its samples as given.
//
// Defaults for binning, derived from the same scale: R = 2 sigma_floor (a bin
// holds values within 2 sigma of its centre), S = 4 sigma_floor (a new bin only
// beyond 4 sigma of every existing one), N_m = max(8, 5% of the samples).
//
// The boundary in view (fit(), boundary_in_view()). Whether the box around
// the seed sees the object's boundary from outside: the object's grey level
// is rare there (its classes hold less than kRareShare of the box's scene)
// and the values it accepts (g >= Gamma, after the Bayes cut) are seldom the
// rivals' (their scene mixture puts less than kRivalShare of the accepted
// mass there: a false discovery rate of the object's own test, read from the
// box's mixture). A tube or horn of its own contrast is such an object (the
// tube phantom: 5% of its box, no rival mass; Colin27's frontal horn of a
// lateral ventricle: 8-11%, 0.3-2.7%), and its mesh may then grow freely
// along it (Params::grey_respacing, automatic). Where the object's grey level
// fills its box (an organ of soft tissue in CT: 46-100% of it; Colin27's
// caudate and putamen: 46-91% under jitter), or a rival class overlaps what
// it accepts (Colin27's thalamus and hippocampus: 10-15% of the accepted mass
// is white or grey matter), its mesh leaks through any gap the model leaves
// open when it grows freely, and does not (BENCHMARKS.md section 12). Not
// in view without a scene (fit_samples(), scene_competitors off).
//
// Samples: the voxels of the smoothed crop whose centres lie in the sphere, at
// most max_samples of them (beyond, the coarsest lattice of box_lattice.h that
// fits: the same voxels of the anatomy when the volume is stored flipped or
// with permuted axes), held in the workspace and sorted: binning and EM then
// see the same values in the same order however the volume was stored.
// Binning visits them in a fixed pseudo-random order (Weyl stride) so the
// first bins are not biased to one end of the range.
//
// Evaluation: g is tabulated from the model alone (kLutStepsPerSigma steps
// per sd of its narrowest class, over +-kTableSigmas sd of every class, at
// most kLutMax entries) and linearly interpolated, whatever the voxel type: a
// u8 volume and an f32 copy of it give the same g (issue 19; the table once
// followed the type's representable values, and u8 read another g than
// f32). Beyond the table g is 0 (g_direct is below 1e-48 there), NaN too.
#pragma once
#include <cstddef>
#include <cstdint>

#include "adaptive_binning.h"
#include "arena.h"
#include "mixture_em.h"
#include "volume.h"

namespace ffseg {

class SmoothedRoi;

struct IntensityModelSettings {
  double bin_radius = 0;              // R, intensity units; 0: 2 sigma_floor
  double bin_separation = 0;          // S, intensity units; 0: 4 sigma_floor
  uint32_t bin_min_count = 0;         // N_m, samples; 0: max(8, 5% of the samples)
  uint32_t em_iterations = 100;
  double sigma_floor_fraction = 0.04; // rho, fraction of the statistics box's p1..p99 range (Params' default)
  bool scene_competitors = true;      // fit(): the crop's other classes compete (see the header note)
  double trim_sds = 2.5;              // fit(): sphere samples kept within this many robust sd of their median; 0: all
  double gamma = 0.2;                 // fit(): Gamma of the search; a scene class explains an object class's mean
                                      // when its peak-normalised density there is at least this (see the header note)
};

// not_finite: the region's noise estimate or intensity range overflowed (grey
// levels beyond float range: the smoothed crop is float).
enum class ModelStatus : int { ok = 0, no_samples, not_carved, bad_settings, not_finite };

class IntensityModel {
 public:
  static constexpr uint32_t kMaxComponents = kMaxMixtureComponents;
  static constexpr uint32_t kMaxBins = kMaxBinningClusters;
  static constexpr uint32_t kLutMax = 16384;
  static constexpr double kLutStepsPerSigma = 32;  // linear interpolation error below 2e-4 of the peak
  static constexpr double kTableSigmas = 15;       // the table's span around each class (g < 1e-48 beyond)
  static constexpr uint32_t kDefaultSamples = 65536;  // a suggested cap (256 KB)
  static constexpr uint32_t kSceneSamples = 16384;    // cap on the crop voxels of the scene mixture
  // The scene fit bins its samples (compress_samples) when it has more than
  // kCompressAbove, kBinsPerSigma bins to the floor, at most kCompressBins.
  static constexpr uint32_t kCompressBins = kMixtureCompressBins;
  static constexpr uint32_t kCompressAbove = 4096;
  static constexpr double kBinsPerSigma = 32;

  // max_samples: cap on the voxels drawn from the sphere; cpu: the engine's
  // kernels (binning, EM).
  void carve(Arena& a, uint32_t max_samples, const CpuDispatch& cpu);

  // Fits the model to the smoothed crop's voxels inside the ball (c, r in mm);
  // the crop should contain the ball (voxels outside it are not seen).
  // raw (the volume the crop was smoothed from; may be nullptr): voxels whose
  // stored value is not finite are left out of the sphere's and the scene's
  // samples. The crop reads them as its 1st percentile (smoothing.h), which
  // is no tissue's value: a NaN patch inside the sphere would otherwise give
  // the object a background class.
  ModelStatus fit(const SmoothedRoi& roi, const double c[3], double r, const IntensityModelSettings& s,
                  char* msg = nullptr, size_t msg_len = 0, const VolumeView* raw = nullptr);
  // Fits to given samples with a given sigma_floor (also sets the binning
  // defaults). x may be this model's own sample buffer.
  ModelStatus fit_samples(const float* x, uint32_t n, double sigma_floor, const IntensityModelSettings& s,
                          char* msg = nullptr, size_t msg_len = 0);

  bool valid() const { return m_ > 0; }
  void reset() { m_ = 0; sm_ = 0; lut_n_ = 0; in_view_ = false; ++generation_; }
  // Counts the changes of the model (carve, every fit, reset): a caller that
  // keeps what it computed from models knows them unchanged while their
  // generations are (the bounding regions' speed table, bounding_region.h).
  uint64_t generation() const { return generation_; }
  // Peak-normalised likelihood in [0, 1] (see the header note); table when there is one.
  double g(double v) const {
    if (lut_n_ > 0) {
      const double f = (v - lut_v0_) * lut_inv_step_;
      if (!(f >= 0 && f <= double(lut_n_ - 1))) return 0.0;  // beyond every class (or NaN)
      const uint32_t i = uint32_t(f);
      if (i + 1 >= lut_n_) return lut_[lut_n_ - 1];
      const double fr = f - double(i);
      return double(lut_[i]) + fr * (double(lut_[i + 1]) - double(lut_[i]));
    }
    return g_direct(v);
  }
  double g_direct(double v) const;
  // The object's posterior against the scene (thesis eq. 6.2.3), the speed of
  // its bounding region's front: P(F | v) = a_o f(v) / (a_o f(v) + sum_c a_c
  // f_c(v) + a_o u), the scene's competing classes as in g and u an outlier
  // class at kOutlierFraction of the object's peak density, so that a value
  // no class explains (far from every mean) reads near 0 instead of 0 / 0.
  // Without competitors it is 1 wherever the object explains v well. Other
  // objects' models (others[0..count)) are in the denominator as well
  // (thesis eq. 6.2.3 with every organ's class in P(I)): each weighs in with
  // its own classes' scene fraction, so a value that another organ explains
  // better slows this object's front. At v[t] into out[t], t < n (0 where
  // v[t] is NaN), for a front's speed table: each class's exps a block at a
  // time (exp_block, std::exp's values bit for bit).
  void posterior_against(const double* v, uint32_t n, const IntensityModel* const* others, uint32_t count,
                         double* out) const;
  // Scene fraction times density of the object's own classes at v.
  double own_density(double v) const { return (sm_ > 0 ? obj_weight_ : 1.0) * density(v); }
  static constexpr double kOutlierFraction = 1e-3;
  // The partial-volume level (intensity_search.cpp): the mean of the object
  // component most probable at v (highest a_i f_i(v)).
  double class_mean(double v) const;
  // When a competing class of the scene is more probable at v than the object
  // (g reads 0 there by the Bayes rule): true, and the mean of the competing
  // class most probable at v. False without competitors or where the object wins.
  bool rival_mean(double v, double* mean) const;

  // The object's classes hold less than this share of the box's scene, and
  // the rivals less than kRivalShare of the values it accepts: its boundary
  // is in view (see the header note).
  static constexpr double kRareShare = 0.25;
  static constexpr double kRivalShare = 0.05;
  bool boundary_in_view() const { return in_view_; }
  // The rivals' share of the mass the object's test accepts (g >= gamma):
  // sum_c a_c f_c over a_o f_obj + sum_c a_c f_c, integrated where g >= gamma.
  // 1 without classes; 0 without rivals.
  double rival_share(double gamma) const;

  uint32_t components() const { return m_; }
  uint32_t competitors() const { return sm_; }
  const Gaussian1& competitor(uint32_t i) const { return scene_[i]; }
  double object_scene_weight() const { return obj_weight_; }
  const Gaussian1& component(uint32_t i) const { return comp_[i]; }
  uint32_t bins_found() const { return bins_; }   // adaptive binning's count, before the cap
  uint32_t sample_count() const { return n_; }
  double sigma_floor() const { return sigma_floor_; }
  bool has_lut() const { return lut_n_ > 0; }
  uint32_t max_samples() const { return cap_; }
  const float* samples() const { return samples_; }

 private:
  double density(double v) const;  // sum_i a_i f_i(v) * sqrt(2 pi)
  // Algorithm 2 + EM over x (mean, m2: the samples' mean and variance) into comp; returns m.
  // hist (3 kCompressBins doubles, may be nullptr): with more than
  // kCompressAbove samples, EM runs over the samples binned kBinsPerSigma
  // to the floor (see compress_samples) instead of sample by sample.
  static uint32_t fit_mixture(const CpuDispatch& cpu, const float* x, uint32_t n, double mean, double m2,
                              double sigma_floor, const IntensityModelSettings& s, Gaussian1* comp,
                              uint32_t* bins_found, double* hist = nullptr);

  void normalise_and_tabulate();
  // fit_samples() without the peak and the table (fit() makes them once, after the scene).
  ModelStatus fit_object(const float* x, uint32_t n, double sigma_floor, const IntensityModelSettings& s,
                         char* msg, size_t msg_len);

  CpuDispatch cpu_;
  float* samples_ = nullptr;
  double* hist_ = nullptr;  // 3 kCompressBins: the scene fit's binned samples
  float* lut_ = nullptr;
  uint32_t cap_ = 0;
  uint32_t n_ = 0;
  uint32_t m_ = 0;
  uint32_t bins_ = 0;
  Gaussian1 comp_[kMaxComponents];
  Gaussian1 scene_[kMaxComponents];  // the scene's competing classes (weights: scene fractions)
  uint32_t sm_ = 0;                  // their number; 0: g alone decides
  double obj_weight_ = 0;            // scene fraction of the object's own classes
  double peak_ = 1;
  double sigma_floor_ = 0;
  uint32_t lut_n_ = 0;
  double lut_v0_ = 0, lut_inv_step_ = 1;
  bool in_view_ = false;
  uint64_t generation_ = 0;
};

}  // namespace ffseg
