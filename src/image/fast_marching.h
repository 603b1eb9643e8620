// Fast marching (Sethian 1996, "A fast marching level set method for
// monotonically advancing fronts"; thesis 6.2, eq. 6.2.1-6.2.5) on a crop of the
// volume grid: the arrival time T of a front leaving a set of seed voxels,
//
//   |grad T(x)| S(x) = 1,   T = 0 on the seeds,
//
// with S >= 0 the speed (mm per unit time) and T in units of mm / speed, so at
// unit speed T is the geodesic distance in millimetres.
//
// Scheme: first-order upwind (Godunov) differences with the real spacing h_a
// of each index axis. At voxel x, for each axis a let t_a be the smaller T of
// the two accepted neighbours along a (the upwind value); the update is the
// largest root of
//
//   sum_{a in U} ((T - t_a) / h_a)^2 = 1 / S(x)^2,
//
// where U holds the axes with t_a < T: axes are added in increasing t_a while
// the root still exceeds the next t_a (the causality condition), so T is never
// computed from a neighbour that arrives later. Accepting voxels in increasing
// T (a min-heap) makes one pass over the crop exact for this discrete system.
//
// Accuracy (unit speed, isotropic h, point source): exact along the axes (T = r)
// and, everywhere else, an overestimate of the Euclidean distance r, at most
// h (0.35 + 0.42 ln(1 + r / h)): the source's singularity is not resolved, so
// the absolute error grows like log r and the relative error falls (on the 3D
// diagonal 32% one voxel out, 6% fifteen voxels out). A plane front is exact.
// tests/image/test_fast_marching.cpp checks these bounds.
//
// Spacing: h_a is the length in mm of one step along index axis a, the column
// norms of the index-to-world matrix (VolumeView::spacing()). The scheme
// assumes the columns are orthogonal (a rotation times a diagonal, as every
// NIfTI qform and every scanner grid): an oblique but orthogonal affine is then
// handled exactly; a sheared one (non-orthogonal columns) is treated as if it
// were orthogonal.
//
// Several fronts (eq. 6.2.5): the thesis computes T_i for each front i
// independently and gives each voxel the label argmin_i T_i(x). march() runs one
// front; merge_labels(i) then folds its times into the running minimum
// (label[x] = i where T_i(x) < best[x]; fronts merged in increasing index give
// ties to the lower index). Each front may have its own speed image: the fronts
// do not interact, exactly as in eq. 6.2.5.
//
// Time cap: march() stops once the next voxel to accept arrives after the cap;
// every voxel not accepted by then is "not reached" (state far, T = +inf), as
// is every voxel where S = 0 (or so small that T overflows).
//
// Memory (carve(), exact two-pass sizes from max_voxels, nothing allocated):
// per voxel a float time, an 8-bit state, a uint32 heap position and an 8-byte
// heap entry; with labels, a float running minimum and a uint16 label. The
// heap's capacity is max_voxels, the number of voxels that can ever be trial at
// once, so a march can never overflow it.
//
// Layout of every per-voxel array and of the speed image: the crop's voxel
// (i, j, k) (relative to the crop's origin) is element i + n0 (j + n1 k).
#pragma once
#include <cstddef>
#include <cstdint>

#include "arena.h"

namespace ffseg {

enum class FmStatus : int {
  ok = 0,
  too_large,   // the crop has more voxels than max_voxels (engine: FFSEG_ERR_ROI_TOO_LARGE)
  not_carved,  // carve() was not run over real memory, or max_voxels was 0
  bad_grid,    // an extent < 1, or a spacing not finite and > 0
  bad_seed,    // a seed outside the crop
  no_labels,   // merge_labels() on a marcher carved without labels
};

class FastMarching {
 public:
  // Voxel states (8 bits, one per voxel).
  static constexpr uint8_t kFar = 0;       // not reached (yet)
  static constexpr uint8_t kTrial = 1;     // in the heap, T tentative
  static constexpr uint8_t kAccepted = 2;  // T final
  static constexpr uint16_t kNoLabel = 0xFFFF;

  // Carves room for crops of at most max_voxels voxels (< 2^32); labels: also
  // the running minimum and label of merge_labels().
  void carve(Arena& a, int64_t max_voxels, bool labels);

  // Sets the crop's extent n[3] (voxels per index axis) and spacing h[3] (mm),
  // clears every time to +inf and every state to far (and, with labels, the
  // running minimum to +inf, every label to kNoLabel). On failure msg (if given)
  // says why; for too_large it names the voxels needed and the bound.
  FmStatus begin(const int64_t n[3], const double h[3], char* msg = nullptr, size_t msg_len = 0);

  // Clears times and states only (the next front on the same crop).
  void clear_front();

  // Makes voxel v (a linear index in the crop) a seed: T = 0. After begin() or
  // clear_front(), before march().
  FmStatus seed(int64_t v);
  FmStatus seed(int64_t i, int64_t j, int64_t k) {
    if (i < 0 || j < 0 || k < 0 || i >= n_[0] || j >= n_[1] || k >= n_[2]) return FmStatus::bad_seed;
    return seed(i + n_[0] * (j + n_[1] * k));
  }

  // Seeds every voxel with mask[v] != 0 (the crop's layout), as seed() would;
  // those whose six face neighbours are all seeds are accepted at T = 0 at
  // once instead of passing through the heap (the same times bit for bit: a
  // voxel inside the seed set can only relax other seeds). For a front that
  // starts from a whole rasterised object.
  FmStatus seed_mask(const uint8_t* mask);

  // Marches from the seeds over speed (one float per crop voxel, >= 0; the
  // caller's array or speed_buffer()) until every reachable voxel is accepted
  // or the next one would arrive after time_cap (+inf: no cap).
  FmStatus march(const float* speed, float time_cap);

  // Folds the last march into the running minimum as front `front` (< kNoLabel).
  FmStatus merge_labels(uint16_t front);

  // A float per crop voxel for the caller's speed image (carved with the rest).
  float* speed_buffer() { return speed_; }

  const float* times() const { return t_; }           // +inf where not reached
  const uint8_t* states() const { return state_; }    // kAccepted where reached
  const float* best_times() const { return best_; }   // labels: min over merged fronts
  const uint16_t* labels() const { return label_; }   // labels: argmin, kNoLabel if none
  int64_t accepted() const { return accepted_; }      // voxels reached by the last march
  int64_t voxel_count() const { return count_; }
  const int64_t* extent() const { return n_; }
  int64_t max_voxels() const { return max_voxels_; }
  bool has_labels() const { return label_ != nullptr; }

 private:
  struct Node {  // a heap entry: the key next to the voxel, one cache line holds 8
    float t;
    uint32_t v;
  };
  void push_or_decrease(uint32_t v, float t);
  void sift_up(uint32_t at, Node x);
  Node pop_min();
  float solve(uint32_t v, uint32_t i, uint32_t j, uint32_t k, float speed) const;

  float* t_ = nullptr;       // final times: +inf until accepted
  uint8_t* state_ = nullptr;
  uint32_t* pos_ = nullptr;  // heap slot of a trial voxel
  Node* heap_ = nullptr;
  float* speed_ = nullptr;
  float* best_ = nullptr;
  uint16_t* label_ = nullptr;
  uint32_t heap_size_ = 0;
  int64_t max_voxels_ = 0;
  int64_t n_[3] = {0, 0, 0};
  int64_t count_ = 0;
  int64_t accepted_ = 0;
  double inv_h2_[3] = {1, 1, 1};  // 1 / h_a^2
  bool begun_ = false;
};

}  // namespace ffseg
