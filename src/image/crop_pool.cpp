#include "crop_pool.h"

#include <cstring>

namespace ffseg {

void CropPool::carve(Arena& a, int64_t voxels, uint32_t owners) {
  cap_ = voxels > 0 ? voxels : 0;
  n_ = owners;
  // Every span starts 16 floats aligned; the room carries that rounding for
  // each owner, so spans of `voxels` floats in all always fit.
  cap_ += 16 * int64_t(owners);
  base_ = a.alloc<float>(size_t(cap_));
  off_ = a.alloc<int64_t>(owners);
  len_ = a.alloc<int64_t>(owners);
  slot_ = a.alloc<float**>(owners);
  if (base_ == nullptr || off_ == nullptr || len_ == nullptr || slot_ == nullptr) {  // measuring
    base_ = nullptr;
    off_ = len_ = nullptr;
    slot_ = nullptr;
    return;
  }
  for (uint32_t k = 0; k < owners; ++k) {
    off_[k] = len_[k] = 0;
    slot_[k] = nullptr;
  }
}

void CropPool::attach(uint32_t k, float** buffer) {
  if (slot_ == nullptr || k >= n_) return;
  slot_[k] = buffer;
  if (buffer) *buffer = nullptr;
}

int64_t CropPool::held() const {
  int64_t h = 0;
  for (uint32_t k = 0; len_ && k < n_; ++k) h += len_[k];
  return h;
}

// Moves every span down to close the gaps, in address order (a span never
// moves up, so memmove in that order never overwrites one not yet moved).
void CropPool::compact() {
  int64_t at = 0;
  for (;;) {
    uint32_t next = n_;
    for (uint32_t k = 0; k < n_; ++k)
      if (len_[k] > 0 && off_[k] >= at && (next == n_ || off_[k] < off_[next])) next = k;
    if (next == n_) return;
    if (off_[next] != at) {
      std::memmove(base_ + at, base_ + off_[next], sizeof(float) * size_t(len_[next]));
      off_[next] = at;
      if (slot_[next]) *slot_[next] = base_ + at;
    }
    at += len_[next];
  }
}

float* CropPool::acquire(uint32_t k, int64_t voxels) {
  if (base_ == nullptr || k >= n_ || voxels < 0) return nullptr;
  const int64_t want = aligned(voxels > 0 ? voxels : 1);
  if (len_[k] >= want) {  // its own span holds it: the rest is given back
    len_[k] = want;
    return base_ + off_[k];
  }
  len_[k] = 0;
  if (slot_[k]) *slot_[k] = nullptr;
  auto end = [&] {
    int64_t e = 0;
    for (uint32_t j = 0; j < n_; ++j)
      if (len_[j] > 0 && off_[j] + len_[j] > e) e = off_[j] + len_[j];
    return e;
  };
  int64_t at = end();
  if (cap_ - at < want) {
    compact();
    at = end();
    if (cap_ - at < want) return nullptr;
  }
  off_[k] = at;
  len_[k] = want;
  if (slot_[k]) *slot_[k] = base_ + at;
  return base_ + at;
}

}  // namespace ffseg
