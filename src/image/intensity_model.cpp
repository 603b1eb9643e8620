#include "intensity_model.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "box_lattice.h"
#include "exp_block.h"
#include "smoothing.h"

#include "fp_contract_off.h"  // after every other include

namespace ffseg {

namespace {

// a f(v) without the constant 1 / sqrt(2 pi): a component's weighted density.
double weighted_density(const Gaussian1& g, double v) {
  const double d = v - g.mean;
  return g.weight / std::sqrt(g.var) * std::exp(-0.5 * d * d / g.var);
}

// N_m of binning for n samples: the settings' count, else max(8, 5% of n); at most n.
// The sphere's robust spread in the raw volume at the acquired samples' own
// positions, on a grid that oversamples (header note; 0 when it does not,
// or when no phase has kMinPhaseSamples voxels). Resampled by L along an
// axis, the voxels of one phase (index mod L) lie on the acquired samples
// where the grids align and carry their whole noise; the voxels between
// hold averages of it. Anatomy reads the same at every phase. So the largest
// spread over the phases is the sphere's spread as acquired, noise and
// anatomy alike. The samples are sorted phase by phase in buf (room for
// cap), the lattice's sphere voxels as fit() reads them.
template <class Inside, class Finite>
double acquired_spread(const SmoothedRoi& roi, const BoxLattice& lat, const Inside& inside, const Finite& finite,
                       const VolumeView* raw, float* buf, uint32_t cap) {
  constexpr uint32_t kMaxPhases = 64;         // L <= 4 over three axes, 8 over two
  constexpr uint32_t kMinPhaseSamples = 8;    // binning's least class (min_count)
  const int64_t L = roi.noise_lag();
  uint32_t phases = 1;
  for (int a = 0; a < 3; ++a)
    if (roi.oversampled(a)) phases *= uint32_t(L);
  if (L < 2 || phases > kMaxPhases) return 0;
  auto phase = [&](int64_t i, int64_t j, int64_t k) {
    const int64_t ix[3] = {i, j, k};
    uint32_t ph = 0;
    for (int a = 0; a < 3; ++a)
      if (roi.oversampled(a)) ph = ph * uint32_t(L) + uint32_t(((ix[a] % L) + L) % L);
    return ph;
  };
  uint32_t start[kMaxPhases + 1] = {}, at[kMaxPhases + 1];
  uint32_t m = 0;
  lat.for_each([&](int64_t i, int64_t j, int64_t k) {
    if (m < cap && inside(i, j, k) && finite(i, j, k)) {
      ++start[phase(i, j, k) + 1];
      ++m;
    }
  });
  for (uint32_t p = 1; p <= phases; ++p) start[p] += start[p - 1];
  for (uint32_t p = 0; p <= phases; ++p) at[p] = start[p];
  m = 0;
  lat.for_each([&](int64_t i, int64_t j, int64_t k) {
    if (m < cap && inside(i, j, k) && finite(i, j, k)) {
      buf[at[phase(i, j, k)]++] = float(raw->at(i, j, k));
      ++m;
    }
  });
  double best = 0;
  for (uint32_t p = 0; p < phases; ++p) {
    const uint32_t b = start[p], n = start[p + 1] - b;
    if (n < kMinPhaseSamples) continue;
    std::sort(buf + b, buf + b + n);
    auto q = [&](double f) { return double(buf[b + uint32_t(f * double(n - 1) + 0.5)]); };
    best = std::max(best, (q(0.75) - q(0.25)) / 1.349);
  }
  return best;
}

uint32_t min_count(const IntensityModelSettings& s, uint32_t n) {
  const uint32_t m = s.bin_min_count > 0 ? s.bin_min_count : std::max<uint32_t>(8, (n + 19) / 20);
  return m > n ? n : m;
}

// The component of c[0..m) with the highest weighted density at v (the first
// of equals); *sum (if given) receives the densities' sum, in index order.
uint32_t most_probable(const Gaussian1* c, uint32_t m, double v, double* sum = nullptr) {
  uint32_t best = 0;
  double bd = -1, s = 0;
  for (uint32_t i = 0; i < m; ++i) {
    const double f = weighted_density(c[i], v);
    s += f;
    if (f > bd) bd = f, best = i;
  }
  if (sum) *sum = s;
  return best;
}

void say(char* msg, size_t n, const char* text) {
  if (msg && n) std::snprintf(msg, n, "%s", text);
}

}  // namespace

void IntensityModel::carve(Arena& a, uint32_t max_samples, const CpuDispatch& cpu) {
  ++generation_;
  cpu_ = cpu;
  cap_ = max_samples;
  samples_ = a.alloc<float>(max_samples);
  hist_ = a.alloc<double>(size_t(3) * kCompressBins);
  lut_ = a.alloc<float>(kLutMax);
  reset();
}

ModelStatus IntensityModel::fit(const SmoothedRoi& roi, const double c[3], double r, const IntensityModelSettings& s,
                                char* msg, size_t msg_len, const VolumeView* raw) {
  auto finite_raw = [&](int64_t i, int64_t j, int64_t k) { return raw == nullptr || std::isfinite(raw->at(i, j, k)); };
  reset();
  if (samples_ == nullptr || cap_ == 0) {
    say(msg, msg_len, "intensity model: sample memory was not carved");
    return ModelStatus::not_carved;
  }
  if (!(std::isfinite(c[0]) && std::isfinite(c[1]) && std::isfinite(c[2]) && std::isfinite(r) && r > 0)) {
    say(msg, msg_len, "intensity model: the sphere is not finite");
    return ModelStatus::bad_settings;
  }
  if (!roi.valid()) {
    say(msg, msg_len, "intensity model: no smoothed region");
    return ModelStatus::no_samples;
  }
  // Index box of the ball, intersected with the stored region.
  double pc[3];
  roi.world_to_index(c, pc);
  int64_t lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    double dir[3] = {0, 0, 0}, row[3];
    // |row a of the inverse affine| = index units per mm along a.
    for (int b = 0; b < 3; ++b) {
      dir[0] = dir[1] = dir[2] = 0;
      dir[b] = 1;
      double p[3];
      roi.world_dir_to_index(dir, p);
      row[b] = p[a];
    }
    const double g = r * std::sqrt(row[0] * row[0] + row[1] * row[1] + row[2] * row[2]);
    const double l = std::ceil(pc[a] - g), h = std::floor(pc[a] + g) + 1;
    // Compared before any conversion: an extreme affine can make the centre
    // or the extent infinite, and l or h NaN or beyond int64_t.
    const double dlo = double(roi.data_lo()[a]), dhi = double(roi.data_hi()[a]);
    if (!(l < dhi && h > dlo)) {
      say(msg, msg_len, "intensity model: the sphere does not meet the smoothed region");
      return ModelStatus::no_samples;
    }
    lo[a] = l < dlo ? roi.data_lo()[a] : int64_t(l);
    hi[a] = h > dhi ? roi.data_hi()[a] : int64_t(h);
    if (lo[a] >= hi[a]) {
      say(msg, msg_len, "intensity model: the sphere does not meet the smoothed region");
      return ModelStatus::no_samples;
    }
  }
  const double r2 = r * r;
  auto inside = [&](int64_t i, int64_t j, int64_t k) {
    const double p[3] = {double(i), double(j), double(k)};
    double w[3];
    roi.index_to_world(p, w);
    const double d0 = w[0] - c[0], d1 = w[1] - c[1], d2 = w[2] - c[2];
    return d0 * d0 + d1 * d1 + d2 * d2 <= r2;
  };
  uint64_t count = 0;
  for (int64_t k = lo[2]; k < hi[2]; ++k)
    for (int64_t j = lo[1]; j < hi[1]; ++j)
      for (int64_t i = lo[0]; i < hi[0]; ++i) count += inside(i, j, k) && finite_raw(i, j, k);
  if (count == 0) {
    say(msg, msg_len, "intensity model: no voxel centre inside the sphere (or none with a finite value)");
    return ModelStatus::no_samples;
  }
  // Every inside voxel when they fit, else those of the coarsest lattice
  // (box_lattice.h) that fits: the same voxels of the anatomy however the
  // volume is stored. Sorted, so that binning and EM see them in one order.
  BoxLattice lat = BoxLattice::with_step(lo, hi, 1);
  auto chosen_inside = [&](const BoxLattice& b) {
    uint64_t c = 0;
    b.for_each([&](int64_t i, int64_t j, int64_t k) { c += inside(i, j, k) && finite_raw(i, j, k); });
    return c;
  };
  for (uint64_t c = count; c > cap_;) {
    lat = BoxLattice::with_step(lo, hi, lat.step + 1);
    c = chosen_inside(lat);
  }
  // The noise the floor reads (header note): the decorrelated estimate where
  // the grid oversamples the noise, at most the sphere's own robust spread in
  // the raw volume (noise is part of that spread), at least the lag-1 one;
  // both at the acquisition's scale (acquisition_gain, acquired_spread).
  double noise = roi.noise_sigma();
  if (raw && roi.decorrelated_noise_sigma() > noise) {
    uint32_t nr = 0;
    lat.for_each([&](int64_t i, int64_t j, int64_t k) {
      if (nr < cap_ && inside(i, j, k) && finite_raw(i, j, k)) samples_[nr++] = float(raw->at(i, j, k));
    });
    if (nr >= 4) {
      std::sort(samples_, samples_ + nr);
      auto q = [&](double f) { return double(samples_[uint32_t(f * double(nr - 1) + 0.5)]); };
      const double spread = (q(0.75) - q(0.25)) / 1.349;
      const double acquired = acquired_spread(roi, lat, inside, finite_raw, raw, samples_, cap_);
      noise = std::max(noise, std::min(roi.acquisition_gain() * roi.decorrelated_noise_sigma(), std::max(spread, acquired)));
    }
  }
  uint32_t n = 0;
  lat.for_each([&](int64_t i, int64_t j, int64_t k) {
    if (n < cap_ && inside(i, j, k) && finite_raw(i, j, k)) samples_[n++] = roi.at(i, j, k);
  });
  std::sort(samples_, samples_ + n);
  // The scene's contrast without its remote classes (smoothing.h), when the
  // object's own level (the sphere's median) is one of the box's near
  // classes; a box held by one flat level other than the object (a
  // noise-free background around a small structure) has fences too narrow
  // to say what is remote from the object, and keeps its whole range.
  const double median = n > 0 ? double(samples_[n / 2]) : 0.0;
  const bool near = median >= roi.fence_low() && median <= roi.fence_high();
  const double range = near ? roi.contrast_high() - roi.contrast_low() : roi.robust_high() - roi.robust_low();
  const double rho = s.sigma_floor_fraction;
  if (!(std::isfinite(rho) && rho >= 0)) {
    say(msg, msg_len, "intensity model: sigma_floor_fraction must be >= 0");
    return ModelStatus::bad_settings;
  }
  const double floor = std::sqrt(noise * noise + rho * range * rho * range);
  if (!std::isfinite(floor)) {
    say(msg, msg_len, "intensity model: the region's noise or intensity range is not finite (grey levels beyond float range)");
    return ModelStatus::not_finite;
  }
  // Trimming (header note): the samples within trim_sds robust sd of their
  // median, a contiguous run of the sorted buffer.
  if (!(std::isfinite(s.trim_sds) && s.trim_sds >= 0)) {
    say(msg, msg_len, "intensity model: trim_sds must be finite and >= 0");
    return ModelStatus::bad_settings;
  }
  uint32_t first = 0, last = n;
  if (s.trim_sds > 0 && n >= 4) {
    auto quantile = [&](double q) { return double(samples_[uint32_t(q * double(n - 1) + 0.5)]); };
    const double median = quantile(0.5);
    const double spread = std::max((quantile(0.75) - quantile(0.25)) / 1.349, floor);
    const double keep_lo = median - s.trim_sds * spread, keep_hi = median + s.trim_sds * spread;
    while (first < n && double(samples_[first]) < keep_lo) ++first;
    while (last > first && double(samples_[last - 1]) > keep_hi) --last;
  }
  // The peak and the table once, when the competition is known.
  const ModelStatus st = fit_object(samples_ + first, last - first, floor, s, msg, msg_len);
  if (st != ModelStatus::ok) return st;
  if (!s.scene_competitors) {
    normalise_and_tabulate();
    return st;
  }

  // The scene: the same mixture fit (Algorithm 2 + EM, same floor) over the
  // crop's statistics box (SmoothingSettings::stats_lo), a lattice of it
  // when it holds more than kSceneSamples (box_lattice.h), sorted, in the
  // sample buffer (the sphere's samples are no longer needed).
  const int64_t* blo = roi.stats_lo();
  const int64_t* bhi = roi.stats_hi();
  const uint32_t scap = cap_ < kSceneSamples ? cap_ : kSceneSamples;
  uint32_t ns = 0;
  BoxLattice::fit(blo, bhi, scap).for_each([&](int64_t i, int64_t j, int64_t k) {
    const float v = roi.at(i, j, k);
    if (ns < scap && std::isfinite(v) && finite_raw(i, j, k)) samples_[ns++] = v;
  });
  std::sort(samples_, samples_ + ns);
  double smean = 0;
  for (uint32_t j = 0; j < ns; ++j) smean += samples_[j];
  if (ns == 0) {
    normalise_and_tabulate();
    return st;
  }
  smean /= ns;
  double sm2 = 0;
  for (uint32_t j = 0; j < ns; ++j) sm2 += (samples_[j] - smean) * (samples_[j] - smean);
  sm2 /= ns;
  Gaussian1 scene[kMaxComponents];
  uint32_t scene_bins = 0;
  const uint32_t sm = fit_mixture(cpu_, samples_, ns, smean, sm2, floor, s, scene, &scene_bins, hist_);
  // The object's classes: the scene components that claim (highest weighted
  // density) the mean of some object component. The others compete.
  bool own[kMaxComponents] = {};
  bool unexplained = false;
  for (uint32_t i = 0; i < m_; ++i) {
    const uint32_t c = most_probable(scene, sm, comp_[i].mean);
    const double z = (comp_[i].mean - scene[c].mean) / std::sqrt(scene[c].var);
    if (std::exp(-0.5 * z * z) >= s.gamma) own[c] = true;
    else unexplained = true;
  }
  obj_weight_ = 0;
  sm_ = 0;
  for (uint32_t c = 0; c < sm; ++c) {
    if (own[c]) obj_weight_ += scene[c].weight;
    else scene_[sm_++] = scene[c];
  }
  if (unexplained) {  // at most binning's minimum share of the box (fit_mixture's N_m)
    obj_weight_ += double(min_count(s, ns)) / double(ns);
  }
  // A competitor more probable than the object at one of the object's own
  // class means would make the object refuse its own sphere's grey level (g
  // = 0 there: no vertex ever finds a boundary). It claims that mean and
  // nearly explains it (a broad class of the box, the portal vein's at 3 mm:
  // -34 +- 40 HU against 41 +- 22), so the box does not tell the two apart,
  // and it is counted as the object's own.
  for (bool moved = true; moved;) {
    moved = false;
    for (uint32_t i = 0; i < m_ && !moved; ++i) {
      const double v = comp_[i].mean;
      double rival = 0;
      const uint32_t c = most_probable(scene_, sm_, v, &rival);
      if (sm_ == 0 || !(rival > obj_weight_ * density(v))) continue;
      obj_weight_ += scene_[c].weight;
      for (uint32_t k = c + 1; k < sm_; ++k) scene_[k - 1] = scene_[k];
      --sm_;
      moved = true;
    }
  }
  normalise_and_tabulate();  // the table includes the competition
  in_view_ = obj_weight_ < kRareShare && rival_share(s.gamma) < kRivalShare;
  return st;
}

ModelStatus IntensityModel::fit_samples(const float* x, uint32_t n, double sigma_floor,
                                        const IntensityModelSettings& s, char* msg, size_t msg_len) {
  in_view_ = false;  // no scene: nothing outside the object is seen
  const ModelStatus st = fit_object(x, n, sigma_floor, s, msg, msg_len);
  if (st == ModelStatus::ok) normalise_and_tabulate();
  return st;
}

ModelStatus IntensityModel::fit_object(const float* x, uint32_t n, double sigma_floor,
                                       const IntensityModelSettings& s, char* msg, size_t msg_len) {
  ++generation_;
  m_ = 0;
  lut_n_ = 0;
  if (n == 0 || x == nullptr) {
    say(msg, msg_len, "intensity model: no samples");
    return ModelStatus::no_samples;
  }
  if (!(std::isfinite(s.bin_radius) && s.bin_radius >= 0 && std::isfinite(s.bin_separation) &&
        s.bin_separation >= 0 && std::isfinite(sigma_floor) && sigma_floor >= 0)) {
    say(msg, msg_len, "intensity model: binning radius/separation and sigma floor must be finite and >= 0");
    return ModelStatus::bad_settings;
  }
  n_ = n;
  sigma_floor_ = sigma_floor;
  double mean = 0, m2 = 0;
  uint32_t nf = 0;
  for (uint32_t j = 0; j < n; ++j)
    if (std::isfinite(x[j])) mean += x[j], ++nf;
  if (nf == 0) {
    say(msg, msg_len, "intensity model: no finite sample");
    return ModelStatus::no_samples;
  }
  mean /= nf;
  for (uint32_t j = 0; j < n; ++j)
    if (std::isfinite(x[j])) m2 += (x[j] - mean) * (x[j] - mean);
  m2 /= nf;
  m_ = fit_mixture(cpu_, x, n, mean, m2, sigma_floor, s, comp_, &bins_);
  sm_ = 0;
  return ModelStatus::ok;
}

uint32_t IntensityModel::fit_mixture(const CpuDispatch& cpu, const float* x, uint32_t n, double mean, double m2,
                                     double sigma_floor, const IntensityModelSettings& s, Gaussian1* comp,
                                     uint32_t* bins_found, double* hist) {
  const double sd = std::sqrt(m2);
  // The scale of the automatic R and S: the floor, else the samples' spread.
  const double ref = sigma_floor > 0 ? sigma_floor : (sd > 0 ? sd : 1.0);
  BinningSettings b;
  b.radius = s.bin_radius > 0 ? s.bin_radius : 2 * ref;
  b.separation = s.bin_separation > 0 ? s.bin_separation : 4 * ref;
  b.min_count = min_count(s, n);
  Bin bins[kMaxComponents];
  *bins_found = adaptive_binning(cpu, x, n, b, bins, kMaxComponents, mixing_stride(n));
  uint32_t m = *bins_found < kMaxComponents ? *bins_found : kMaxComponents;
  const double vfloor = sigma_floor * sigma_floor;
  if (m == 0) {  // every bin fell under N_m: one component over all samples
    comp[0].weight = 1;
    comp[0].mean = mean;
    comp[0].var = std::max(m2, vfloor);
    m = 1;
  } else {
    double total = 0;
    for (uint32_t i = 0; i < m; ++i) total += bins[i].count;
    for (uint32_t i = 0; i < m; ++i) {
      comp[i].weight = bins[i].count / total;
      comp[i].mean = bins[i].centroid;
      comp[i].var = std::max(bins[i].var, vfloor);
    }
  }
  if (hist && n > kCompressAbove) {
    // Many samples (the scene): EM over bins a 32nd of the floor wide.
    em_fit_compressed(cpu, x, n, comp, &m, s.em_iterations, vfloor, ref / kBinsPerSigma, hist, 1e-9);
  } else {
    em_fit(cpu, x, n, comp, &m, s.em_iterations, vfloor, 1e-9, false);
  }
  return m;
}

double IntensityModel::density(double v) const {
  double s = 0;
  for (uint32_t i = 0; i < m_; ++i) s += weighted_density(comp_[i], v);
  return s;
}

double IntensityModel::class_mean(double v) const { return m_ ? comp_[most_probable(comp_, m_, v)].mean : 0.0; }

bool IntensityModel::rival_mean(double v, double* mean) const {
  if (m_ == 0 || sm_ == 0 || !(v == v)) return false;
  double rival = 0;
  *mean = scene_[most_probable(scene_, sm_, v, &rival)].mean;
  return rival > obj_weight_ * density(v);
}

double IntensityModel::g_direct(double v) const {
  if (m_ == 0 || !(v == v)) return 0;
  const double dv = density(v);
  if (sm_ > 0) {  // a competing class of the scene is more probable: not object
    double rival = 0;
    for (uint32_t c = 0; c < sm_; ++c) rival += weighted_density(scene_[c], v);
    if (rival > obj_weight_ * dv) return 0;
  }
  const double g = dv / peak_;
  return g < 1 ? g : 1;
}

double IntensityModel::rival_share(double gamma) const {
  if (m_ == 0) return 1.0;
  if (sm_ == 0) return 0.0;
  // Every value g accepts lies within a few sd of some object class (g is
  // the mixture's density over its peak); the sum runs over +-5 sd of each
  // on a grid of a 64th of the narrowest (at most 2^16 points: classes far
  // apart), fine against any class's width.
  double lo = INFINITY, hi = -INFINITY, step = INFINITY;
  for (uint32_t i = 0; i < m_; ++i) {
    const double sd = std::sqrt(comp_[i].var);
    lo = std::fmin(lo, comp_[i].mean - 5 * sd);
    hi = std::fmax(hi, comp_[i].mean + 5 * sd);
    step = std::fmin(step, sd / 64);
  }
  if (!(step > 0) || !std::isfinite(hi - lo)) return 1.0;
  double own = 0, rival = 0;
  const uint32_t n = uint32_t(std::fmin((hi - lo) / step, 65536.0));
  for (uint32_t j = 0; j <= n; ++j) {
    const double v = lo + (hi - lo) * j / n;
    if (g_direct(v) < gamma) continue;
    own += obj_weight_ * density(v);
    for (uint32_t c = 0; c < sm_; ++c) rival += weighted_density(scene_[c], v);
  }
  return own + rival > 0 ? rival / (own + rival) : 1.0;
}

namespace {

constexpr uint32_t kPosteriorBlock = 256;

// acc[t] += weighted_density(g, v[t]) for t < n, each term as weighted_density
// evaluates it; e: scratch of n.
void add_weighted_density(const CpuDispatch& cpu, const Gaussian1& g, const double* v, uint32_t n, double* e,
                          double* acc) {
  for (uint32_t t = 0; t < n; ++t) {
    const double d = v[t] - g.mean;
    e[t] = -0.5 * d * d / g.var;
  }
  exp_block(cpu, e, n);
  const double c = g.weight / std::sqrt(g.var);
  for (uint32_t t = 0; t < n; ++t) acc[t] += c * e[t];
}

}  // namespace

void IntensityModel::posterior_against(const double* v, uint32_t n, const IntensityModel* const* others,
                                       uint32_t count, double* out) const {
  double own[kPosteriorBlock], rival[kPosteriorBlock], dens[kPosteriorBlock], e[kPosteriorBlock];
  for (uint32_t first = 0; first < n; first += kPosteriorBlock) {
    const uint32_t b = n - first < kPosteriorBlock ? n - first : kPosteriorBlock;
    const double* x = v + first;
    if (m_ == 0) {
      for (uint32_t t = 0; t < b; ++t) out[first + t] = 0;
      continue;
    }
    const double a = sm_ > 0 ? obj_weight_ : 1.0;
    for (uint32_t t = 0; t < b; ++t) own[t] = rival[t] = 0;
    for (uint32_t i = 0; i < m_; ++i) add_weighted_density(cpu_, comp_[i], x, b, e, own);
    for (uint32_t t = 0; t < b; ++t) own[t] = a * own[t];
    for (uint32_t c = 0; c < sm_; ++c) add_weighted_density(cpu_, scene_[c], x, b, e, rival);
    for (uint32_t o = 0; o < count; ++o) {
      const IntensityModel& other = *others[o];
      if (&other == this || !other.valid()) continue;
      for (uint32_t t = 0; t < b; ++t) dens[t] = 0;
      for (uint32_t i = 0; i < other.m_; ++i) add_weighted_density(cpu_, other.comp_[i], x, b, e, dens);
      const double w = other.sm_ > 0 ? other.obj_weight_ : 1.0;
      for (uint32_t t = 0; t < b; ++t) rival[t] += w * dens[t];
    }
    const double outlier = a * kOutlierFraction * peak_;
    for (uint32_t t = 0; t < b; ++t) {
      const double den = own[t] + rival[t] + outlier;
      out[first + t] = !(x[t] == x[t]) ? 0.0 : den > 0 ? own[t] / den : 0.0;
    }
  }
}

void IntensityModel::normalise_and_tabulate() {
  // Peak of the mixture: a grid over mu +- 4 sigma and every mean, then a
  // golden-section refinement around the best grid point.
  double lo = INFINITY, hi = -INFINITY, best_v = comp_[0].mean, best = 0;
  for (uint32_t i = 0; i < m_; ++i) {
    const double sd = std::sqrt(comp_[i].var);
    lo = std::min(lo, comp_[i].mean - 4 * sd);
    hi = std::max(hi, comp_[i].mean + 4 * sd);
    const double d = density(comp_[i].mean);
    if (d > best) best = d, best_v = comp_[i].mean;
  }
  const int kGrid = 4096;
  const double h = (hi - lo) / kGrid;
  for (int t = 0; t <= kGrid; ++t) {
    const double v = lo + h * t;
    const double d = density(v);
    if (d > best) best = d, best_v = v;
  }
  double a = best_v - h, b = best_v + h;
  const double gr = 0.6180339887498949;
  for (int it = 0; it < 60; ++it) {
    const double c1 = b - gr * (b - a), c2 = a + gr * (b - a);
    if (density(c1) > density(c2)) b = c2; else a = c1;
  }
  best = std::max(best, density(0.5 * (a + b)));
  peak_ = best > 0 ? best : 1;

  // Beyond kTableSigmas sd of every class each exp is below e^-112, so g is
  // under 1e-48: below the least float, which the table would store as 0.
  // The table spans the classes' +-kTableSigmas and g reads 0 beyond it.
  double vlo = INFINITY, vhi = -INFINITY;
  auto widen = [&](const Gaussian1& c) {
    const double w = kTableSigmas * std::sqrt(c.var) * (1 + 1e-6) + 1e-6 * std::fabs(c.mean) + 1e-300;
    vlo = std::min(vlo, c.mean - w);
    vhi = std::max(vhi, c.mean + w);
  };
  for (uint32_t i = 0; i < m_; ++i) widen(comp_[i]);
  for (uint32_t c = 0; c < sm_; ++c) widen(scene_[c]);
  // The table: g_direct at steps of a kLutStepsPerSigma-th of the narrowest
  // class's sd over that span, linear in between; it depends on the model
  // only, so the same values give the same g whatever type stored them.
  lut_n_ = 0;
  double sd_min = INFINITY;
  for (uint32_t i = 0; i < m_; ++i) sd_min = std::min(sd_min, std::sqrt(comp_[i].var));
  for (uint32_t c = 0; c < sm_; ++c) sd_min = std::min(sd_min, std::sqrt(scene_[c].var));
  const double span = vhi - vlo;
  double step = sd_min / kLutStepsPerSigma;
  if (lut_ == nullptr || !std::isfinite(span) || !(span > 0) || !(step > 0)) return;
  if (span / step > double(kLutMax - 2)) step = span / double(kLutMax - 2);
  const uint32_t count = uint32_t(std::ceil(span / step)) + 1;
  lut_v0_ = vlo;
  lut_inv_step_ = 1.0 / step;
  for (uint32_t i = 0; i < count; ++i) lut_[i] = float(g_direct(vlo + step * double(i)));
  lut_n_ = count;
}

}  // namespace ffseg
