#include "fast_marching.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

namespace ffseg {

namespace {
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr uint32_t kArity = 4;  // 4 children: one sift-down step reads 32 bytes of siblings

void put_msg(char* msg, size_t len, const char* text) {
  if (msg && len) std::snprintf(msg, len, "%s", text);
}
}  // namespace

void FastMarching::carve(Arena& a, int64_t max_voxels, bool labels) {
  // Voxel indices and heap slots are 32-bit; a crop of 2^32 voxels would be 64 GB of times alone.
  const bool fits = max_voxels > 0 && max_voxels < int64_t(UINT32_MAX);
  const size_t m = fits ? size_t(max_voxels) : 0;
  t_ = a.alloc<float>(m);
  state_ = a.alloc<uint8_t>(m);
  pos_ = a.alloc<uint32_t>(m);
  heap_ = a.alloc<Node>(m);
  speed_ = a.alloc<float>(m);
  best_ = labels ? a.alloc<float>(m) : nullptr;
  label_ = labels ? a.alloc<uint16_t>(m) : nullptr;
  max_voxels_ = (fits && !a.measuring() && a.ok()) ? max_voxels : 0;
  begun_ = false;
  count_ = accepted_ = 0;
  heap_size_ = 0;
}

FmStatus FastMarching::begin(const int64_t n[3], const double h[3], char* msg, size_t msg_len) {
  begun_ = false;
  if (max_voxels_ <= 0 || t_ == nullptr) {
    put_msg(msg, msg_len, "fast marching: workspace not carved");
    return FmStatus::not_carved;
  }
  for (int a = 0; a < 3; ++a) {
    if (n[a] < 1 || !(std::isfinite(h[a]) && h[a] > 0)) {
      if (msg && msg_len)
        std::snprintf(msg, msg_len, "fast marching: bad crop (extent %lld x %lld x %lld, spacing %g x %g x %g mm)",
                      (long long)n[0], (long long)n[1], (long long)n[2], h[0], h[1], h[2]);
      return FmStatus::bad_grid;
    }
  }
  // Product checked factor by factor so that no extent can overflow it.
  int64_t count = 1;
  bool over = false;
  for (int a = 0; a < 3; ++a) {
    if (n[a] > max_voxels_ / count) over = true;
    else count *= n[a];
  }
  if (over || count > max_voxels_) {
    if (msg && msg_len) {
      const double need = double(n[0]) * double(n[1]) * double(n[2]);
      std::snprintf(msg, msg_len,
                    "fast marching crop of %.0f voxels (%lld x %lld x %lld) exceeds max_roi_voxels = %lld",
                    need, (long long)n[0], (long long)n[1], (long long)n[2], (long long)max_voxels_);
    }
    return FmStatus::too_large;
  }
  for (int a = 0; a < 3; ++a) {
    n_[a] = n[a];
    inv_h2_[a] = 1.0 / (h[a] * h[a]);
  }
  count_ = count;
  begun_ = true;
  clear_front();
  if (label_) {
    for (int64_t v = 0; v < count_; ++v) best_[v] = kInf;
    for (int64_t v = 0; v < count_; ++v) label_[v] = kNoLabel;
  }
  return FmStatus::ok;
}

void FastMarching::clear_front() {
  if (!begun_) return;
  for (int64_t v = 0; v < count_; ++v) t_[v] = kInf;
  std::memset(state_, kFar, size_t(count_));
  heap_size_ = 0;
  accepted_ = 0;
}

FmStatus FastMarching::seed(int64_t v) {
  if (!begun_) return FmStatus::not_carved;
  if (v < 0 || v >= count_) return FmStatus::bad_seed;
  const uint32_t u = uint32_t(v);
  if (state_[u] == kTrial) return FmStatus::ok;  // seeded twice (every key is 0 before march())
  push_or_decrease(u, 0.0f);
  return FmStatus::ok;
}

FmStatus FastMarching::seed_mask(const uint8_t* mask) {
  if (!begun_) return FmStatus::not_carved;
  const int64_t n0 = n_[0], n1 = n_[1], n01 = n0 * n1;
  for (int64_t k = 0, v = 0; k < n_[2]; ++k)
    for (int64_t j = 0; j < n1; ++j)
      for (int64_t i = 0; i < n0; ++i, ++v) {
        if (!mask[v] || state_[v] != kFar) continue;
        // Inside the seed set (every face neighbour a seed): accepted at once,
        // it could only ever relax other seeds.
        const bool interior = i > 0 && i + 1 < n0 && j > 0 && j + 1 < n1 && k > 0 && k + 1 < n_[2] &&
                              mask[v - 1] && mask[v + 1] && mask[v - n0] && mask[v + n0] && mask[v - n01] &&
                              mask[v + n01];
        if (interior) {
          state_[v] = kAccepted;
          t_[v] = 0.0f;
          ++accepted_;
        } else {
          push_or_decrease(uint32_t(v), 0.0f);
        }
      }
  return FmStatus::ok;
}

void FastMarching::sift_up(uint32_t at, Node x) {
  while (at > 0) {
    const uint32_t parent = (at - 1) / kArity;
    if (!(x.t < heap_[parent].t)) break;
    heap_[at] = heap_[parent];
    pos_[heap_[at].v] = at;
    at = parent;
  }
  heap_[at] = x;
  pos_[x.v] = at;
}

// A trial voxel's tentative time lives only in its heap entry: t_ holds final
// times, so the upwind stencil reads one array and no states.
void FastMarching::push_or_decrease(uint32_t v, float t) {
  if (state_[v] == kTrial) {
    if (t < heap_[pos_[v]].t) sift_up(pos_[v], Node{t, v});  // decrease-key
  } else {
    state_[v] = kTrial;
    sift_up(heap_size_++, Node{t, v});
  }
}

FastMarching::Node FastMarching::pop_min() {
  const Node top = heap_[0];
  const Node last = heap_[--heap_size_];
  const uint32_t size = heap_size_;
  uint32_t at = 0;
  for (;;) {
    const uint32_t first = at * kArity + 1;
    if (first >= size) break;
    uint32_t best = first;
    float bt = heap_[first].t;
    const uint32_t end = first + kArity < size ? first + kArity : size;
    for (uint32_t c = first + 1; c < end; ++c)
      if (heap_[c].t < bt) { bt = heap_[c].t; best = c; }
    if (!(bt < last.t)) break;
    heap_[at] = heap_[best];
    pos_[heap_[at].v] = at;
    at = best;
  }
  if (size > 0) {
    heap_[at] = last;
    pos_[last.v] = at;
  }
  return top;
}

// The upwind update at voxel v = (i, j, k) from its accepted neighbours.
// t_ is +inf except at accepted voxels, so the smaller neighbour per axis is
// the upwind value without a look at the states.
float FastMarching::solve(uint32_t v, uint32_t i, uint32_t j, uint32_t k, float speed) const {
  if (!(speed > 0.0f)) return kInf;
  const uint32_t c[3] = {i, j, k};
  const uint32_t stride[3] = {1, uint32_t(n_[0]), uint32_t(n_[0] * n_[1])};
  const uint32_t last[3] = {uint32_t(n_[0] - 1), uint32_t(n_[1] - 1), uint32_t(n_[2] - 1)};
  double tv[3];
  double wv[3];
  int m = 0;
  for (int a = 0; a < 3; ++a) {
    float best = c[a] > 0 ? t_[v - stride[a]] : kInf;
    if (c[a] < last[a] && t_[v + stride[a]] < best) best = t_[v + stride[a]];
    if (best < kInf) {
      // Insertion into the ascending list (at most 3 entries).
      int p = m++;
      while (p > 0 && tv[p - 1] > double(best)) {
        tv[p] = tv[p - 1];
        wv[p] = wv[p - 1];
        --p;
      }
      tv[p] = double(best);
      wv[p] = inv_h2_[a];
    }
  }
  if (m == 0) return kInf;
  const double s = double(speed);
  const double rhs = 1.0 / (s * s);
  // sum w_a (T - t_a)^2 = rhs: A T^2 - 2 B T + C = 0 over the axes in use.
  double A = 0, B = 0, C = -rhs;
  double sol = std::numeric_limits<double>::infinity();
  for (int p = 0; p < m; ++p) {
    if (sol < tv[p]) break;  // causality: a later neighbour cannot be upwind
    A += wv[p];
    B += wv[p] * tv[p];
    C += wv[p] * tv[p] * tv[p];
    const double disc = B * B - A * C;
    if (disc < 0) break;  // rounding only: keep the root of the smaller system
    sol = (B + std::sqrt(disc)) / A;
  }
  return float(sol);  // overflows to +inf for speeds too small to arrive
}

FmStatus FastMarching::march(const float* speed, float time_cap) {
  if (!begun_) return FmStatus::not_carved;
  // 32-bit coordinates: a 32-bit division is several times cheaper than a 64-bit one.
  const uint32_t n0 = uint32_t(n_[0]), n1 = uint32_t(n_[1]), n2 = uint32_t(n_[2]);
  const uint32_t n01 = n0 * n1;
  while (heap_size_ > 0) {
    if (heap_[0].t > time_cap) break;
    const Node top = pop_min();
    const uint32_t v = top.v;
    state_[v] = kAccepted;
    t_[v] = top.t;
    ++accepted_;
    const uint32_t k = v / n01;
    const uint32_t r = v - k * n01;
    const uint32_t j = r / n0;
    const uint32_t i = r - j * n0;
    // The six face neighbours: only they can have v in their upwind stencil.
    // Accepted ones hold a finite time (and are final).
    auto relax = [&](uint32_t u, uint32_t iu, uint32_t ju, uint32_t ku) {
      if (t_[u] < kInf) return;
      const float t = solve(u, iu, ju, ku, speed[u]);
      if (t < kInf) push_or_decrease(u, t);
    };
    if (i > 0) relax(v - 1, i - 1, j, k);
    if (i + 1 < n0) relax(v + 1, i + 1, j, k);
    if (j > 0) relax(v - n0, i, j - 1, k);
    if (j + 1 < n1) relax(v + n0, i, j + 1, k);
    if (k > 0) relax(v - n01, i, j, k - 1);
    if (k + 1 < n2) relax(v + n01, i, j, k + 1);
  }
  // Beyond the cap: whatever is still trial was not reached (its t_ is still +inf).
  for (uint32_t p = 0; p < heap_size_; ++p) state_[heap_[p].v] = kFar;
  heap_size_ = 0;
  return FmStatus::ok;
}

FmStatus FastMarching::merge_labels(uint16_t front) {
  if (!begun_) return FmStatus::not_carved;
  if (label_ == nullptr || front == kNoLabel) return FmStatus::no_labels;
  for (int64_t v = 0; v < count_; ++v) {
    if (t_[v] < best_[v]) {  // unreached voxels hold +inf and never win
      best_[v] = t_[v];
      label_[v] = front;
    }
  }
  return FmStatus::ok;
}

}  // namespace ffseg
