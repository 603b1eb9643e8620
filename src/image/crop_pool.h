// One room for several objects' smoothed crops (issue 30: memory that follows
// the organs, not the scan).
//
// Each object of an engine used to carve its own crop of max_roi_voxels, so
// the workspace held objects x the largest crop any of them might need: a
// liver and fifteen smaller organs on a 1 mm grid asked for sixteen livers'
// room, and with a room per object that the budget could afford the liver
// did not fit (its crop grew to 4.2 M voxels against 3.4 M each; the tool
// started again with twice the memory). Here the objects' crops share one
// buffer of objects x max_roi_voxels floats, so a large organ may hold more
// while the small ones hold less.
//
// Spans are contiguous (the smoothing sweeps a crop as one array) and
// 64-byte aligned. An owner asking for more than its span gives its span up
// (the crop it held is recomputed anyway) and takes the free room after the
// last span; when that is too short the other spans are moved down, in
// address order, to close the gaps (memmove, their contents kept, each
// owner's buffer pointer updated through the address it attached), and the
// owner takes the room after them. It fails only when the spans held plus the
// new one exceed the room.
#pragma once
#include <cstdint>

#include "arena.h"

namespace ffseg {

class CropPool {
 public:
  // Room for `voxels` floats shared by `owners` owners.
  void carve(Arena& a, int64_t voxels, uint32_t owners);
  // Owner k's buffer pointer, which the pool sets and moves (nullptr while it
  // holds no span). A measuring carve keeps nothing.
  void attach(uint32_t k, float** buffer);

  int64_t capacity() const { return cap_; }
  // A span of `voxels` floats for owner k (its content undefined), or
  // nullptr when the room cannot hold it beside the other spans; owner k then
  // holds none. Other owners' spans may move (their contents kept).
  float* acquire(uint32_t k, int64_t voxels);
  // Floats held by all spans, and by owner k's.
  int64_t held() const;
  int64_t held_by(uint32_t k) const { return k < n_ && len_ ? len_[k] : 0; }

 private:
  static int64_t aligned(int64_t floats) { return (floats + 15) & ~int64_t(15); }
  void compact();

  float* base_ = nullptr;
  int64_t cap_ = 0;
  uint32_t n_ = 0;
  int64_t* off_ = nullptr;  // per owner: span start (floats from base_)
  int64_t* len_ = nullptr;  // per owner: span length in floats, 0 = none
  float*** slot_ = nullptr; // per owner: where its buffer pointer lives
};

}  // namespace ffseg
