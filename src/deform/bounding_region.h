// Bounding regions of several objects (thesis 6.2, eq. 6.2.1-6.2.11; METHOD.md
// section 4): each object deforms inside the voxels that its own front
// reaches first.
//
// For object i: the box BB_i is the bounding box of its mesh in volume index
// space grown by w_i mm (eq. 6.2.6-6.2.11: w_i / h_a voxels along axis a),
// clipped to the grid. Inside it, fast marching (image/fast_marching.h) solves
// |grad T_i| S_i = 1 from the voxels whose centres lie inside the mesh (and
// the voxel nearest to each vertex, so that a mesh thinner than a voxel still
// has a front), up to the time cap w_i: with S_i <= 1 a front never gets
// further than w_i mm from the mesh, so the box never cuts it off.
//
// Speed S_i (eq. 6.2.2-6.2.3): grey-level targets, the object's posterior
// against the scene's other classes and the other objects' own classes
// (IntensityModel::posterior_against()) of the smoothed value (the raw value
// outside the smoothed crop), so a front runs through the object's tissue and
// crawls through its neighbours', and two organs of one tissue share it. It
// is tabulated once per front over the box's range of values (kSpeedTable
// entries, linear in between): the models' densities are not evaluated per
// voxel; binary targets, 1 on the
// non-zero voxels and 0 elsewhere, so an object's region is the part of the
// non-zero voxels that its front reaches first (two objects in separate
// blobs never compete; in one blob they split where the fronts meet).
// Non-finite voxels have speed 0.
//
// Ownership (eq. 6.2.5): object i owns voxel x when T_i(x) <= cap_i and no
// other object's front arrives earlier (ties go to the lower object index,
// so the regions are disjoint and deterministic). A voxel nobody reaches is
// background. Only the times are stored (4 bytes per box voxel per object);
// ownership is decided when asked, from every object's times at x.
//
// Cells (thesis 7.2: "the bounding region needs not to be of single voxel
// accuracy"): a box with more voxels than the marcher holds is marched on
// cells of f_a voxels along index axis a instead, the finest cells whose box
// fits, as near cubic in mm as the grid allows (f_a = round(c h_min / h_a)
// for c = 1, 2, ...: on 0.7 x 0.7 x 5 mm CT the slices stay whole until the
// cells reach 5 mm in-plane). A cell's speed is the mean of its voxels',
// its seed state whether its centre lies inside the mesh, and each of its
// voxels takes its time (piecewise constant: a region's border is then
// placed to within a cell). Cells are aligned with the grid (cell c holds
// voxels f c .. f c + f - 1), so the cells stay put when the box moves. Cells
// coarser than half the region width w_i are refused (too_large): the band of
// w_i around the mesh would then be less than two cells deep, no region. So the
// workspace stays fixed by the configuration, and a large box costs accuracy
// of the regions' borders only, never memory.
#pragma once
#include <cstddef>
#include <cstdint>

#include "arena.h"
#include "cubesphere.h"
#include "fast_marching.h"
#include "intensity_model.h"
#include "smoothing.h"
#include "spatial_grid.h"  // floor_i64
#include "volume.h"

namespace ffseg {

// Entries of a speed table: the front's speed (the posterior of eq.
// 6.2.2-6.2.3) tabulated over the box's value range, linear in between.
constexpr int kSpeedTableSize = 4096;

// A region's last speed table, kept for its next computation: between two
// computations of an object's region the models seldom change, and the
// value range of its box often not at all (the nine abdominal organs at 3
// mm: 56 of 141 tables the same), while a table costs 16 blocks of the
// posterior's exps per class of every model.
struct SpeedTableCache {
  float* table = nullptr;  // kSpeedTableSize entries (nullptr: none kept)
  double lo = 0, hi = 0;   // the value range it was made for
  uint64_t epoch = 0;      // RegionSpeed::models_epoch it was made at (0: none)
};

struct RegionMap {
  int64_t lo[3] = {0, 0, 0};  // the box's first voxel (volume index space)
  int64_t n[3] = {0, 0, 0};   // its extent, voxels
  int64_t f[3] = {1, 1, 1};   // voxels per cell along each axis (1: the volume's own grid)
  int64_t clo[3] = {0, 0, 0}; // the box's first cell (cell index space: voxel i is in cell i / f)
  int64_t cn[3] = {0, 0, 0};  // its extent, cells
  float cap = 0;              // time cap (mm at unit speed)
  float* t = nullptr;         // arrival times, cell box layout c0 + cn0 (c1 + cn1 c2); +inf: not reached
  int64_t reached = 0;        // cells reached within the cap
  uint32_t computed_at = 0;   // the engine step that computed it
  SpeedTableCache speed;
  bool valid = false;
  // speed_table: room for the kept speed table (grey levels; a binary
  // front's speed is the indicator, no table).
  void carve(Arena& a, int64_t max_voxels, bool speed_table);
  bool unit_cells() const { return f[0] == 1 && f[1] == 1 && f[2] == 1; }
  // Arrival time at voxel (i, j, k) of the volume grid (its cell's); +inf
  // outside the box. The ownership test asks it of every region at every
  // voxel a search meets: one unsigned comparison per axis, an index below
  // the box wrapping to beyond every extent.
  float time_at(int64_t i, int64_t j, int64_t k) const {
    const uint64_t di = uint64_t(i) - uint64_t(lo[0]), dj = uint64_t(j) - uint64_t(lo[1]),
                   dk = uint64_t(k) - uint64_t(lo[2]);
    if (di >= uint64_t(n[0]) || dj >= uint64_t(n[1]) || dk >= uint64_t(n[2])) return kNotReached;
    if (unit_cells()) return t[di + uint64_t(n[0]) * (dj + uint64_t(n[1]) * dk)];
    return t[(i / f[0] - clo[0]) + cn[0] * ((j / f[1] - clo[1]) + cn[1] * (k / f[2] - clo[2]))];
  }
  // Whether the mesh at x (3 per vertex, mm) still lies in the inner part of
  // the box, at least margin_mm from its faces where the grid goes on.
  bool holds(const VolumeView& vol, const double* x, uint32_t nv, double margin_mm) const;
  static constexpr float kNotReached = 3.0e38f;
};

// What drives a front: the object's intensity model over its smoothed crop,
// or (model == nullptr) the binary indicator of the volume.
struct RegionSpeed {
  const IntensityModel* model = nullptr;
  const SmoothedRoi* roi = nullptr;
  // The other objects' models, competing in the posterior's denominator.
  const IntensityModel* const* others = nullptr;
  uint32_t other_count = 0;
  // The sum of the generations (IntensityModel::generation()) of every
  // model the caller holds, these among them: it grows with any change of
  // any of them, so a table made at the same epoch over the same range is
  // this speed's. 0: unknown (no table is kept).
  uint64_t models_epoch = 0;
};

enum class RegionStatus : int { ok = 0, too_large, off_grid };

// The cells a box of n voxels (spacing h mm) is marched on: the finest f
// (f_a = max(1, round(c h_min / h_a)), c = 1, 2, ...) whose cells, aligned
// with the grid, number at most max_cells over the box starting at voxel lo.
// False when the cells would be coarser than max_cell_mm along some axis first.
bool region_cells(const int64_t lo[3], const int64_t n[3], const double h[3], int64_t max_cells, double max_cell_mm,
                  int64_t f[3]);

// Object's region: the box around mesh x grown by width_mm, the front from
// its inside (seed_mask: scratch of fm.max_voxels() bytes), its times into out
// (on cells when the box holds more than fm.max_voxels() voxels).
RegionStatus compute_region(const CubeSphere& m, const double* x, const VolumeView& vol, const RegionSpeed& speed,
                            double width_mm, FastMarching& fm, uint8_t* seed_mask, RegionMap& out, char* msg,
                            size_t msg_len);

// Nearest voxel of index-space point p, false off the grid. Inline: the
// searches ask it of every sample along every ray (RegionLimit::foreign).
inline bool nearest_voxel(const VolumeView& vol, const double p[3], int64_t q[3]) {
  const int64_t* D = vol.dims();
  for (int a = 0; a < 3; ++a) {
    if (!(p[a] > -0.5 && p[a] < double(D[a]) - 0.5)) return false;
    q[a] = floor_i64(p[a] + 0.5);
    if (q[a] >= D[a]) q[a] = D[a] - 1;
  }
  return true;
}

// Every object's region at once, for the ownership test: regions[i] for
// object i < count (invalid ones own nothing and claim nothing).
struct RegionSet {
  const RegionMap* regions = nullptr;
  uint32_t count = 0;
  static constexpr uint32_t kNobody = 0xFFFFFFFFu;
  // The object owning voxel (i, j, k), or kNobody.
  uint32_t owner(int64_t i, int64_t j, int64_t k) const;
  bool owns(uint32_t object, int64_t i, int64_t j, int64_t k) const;
};

// A search's view of the regions (thesis 6.3): a sample that another
// object owns stops object's ray at the sample before it, and the vertex is
// a border vertex. Background samples (no front reached them) do not stop a
// ray: the intensity model or the indicator decides there, as for one object.
struct RegionLimit {
  const RegionSet* set = nullptr;
  const VolumeView* vol = nullptr;
  uint32_t object = 0;
  // Whether the sample at index-space point p belongs to another object.
  // A ray's samples lie half a voxel apart or closer, so most fall in the
  // voxel of the sample before: its owner is kept (the regions do not
  // change while a search holds the limit) instead of asked of every region
  // again.
  bool foreign(const double p[3]) const {
    int64_t q[3];
    if (!nearest_voxel(*vol, p, q)) return false;  // off the grid: nobody's
    if (q[0] != last_[0] || q[1] != last_[1] || q[2] != last_[2]) {
      for (int a = 0; a < 3; ++a) last_[a] = q[a];
      last_owner_ = set->owner(q[0], q[1], q[2]);
    }
    return last_owner_ != object && last_owner_ != RegionSet::kNobody;
  }
  mutable int64_t last_[3] = {-1, -1, -1};  // no voxel yet (voxels are >= 0)
  mutable uint32_t last_owner_ = RegionSet::kNobody;
};

}  // namespace ffseg
