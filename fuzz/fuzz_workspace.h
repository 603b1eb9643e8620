// Workspace blocks reused by every input of a fuzz target.
//
// ReusedBlock: a fresh multi-megabyte allocation per input (the intensity-model
// buffers make even an n = 2 engine 0.8 MB per object) cost more than the
// engine's own work: page faults and ASan's fill of new chunks. Instead the
// block stays and ASan poisoning marks everything outside [p, p + bytes)
// unaddressable, so a read or write past what the engine was given is still
// reported at once.
//
// CreatedEngine: an engine of one configuration, created once and restored for
// every later input. ffseg_create's result depends only on the configuration
// and the workspace's address (the determinism tests create into workspaces
// pre-filled with 0x00, 0xFF and dirty ones and get the same engine), and
// building the mesh, its Laplacian program and the solver's pattern took a
// quarter of fuzz_volume's time, the same work for every input of a mesh
// size. The first input of a configuration runs ffseg_create (so its code is
// covered); later ones get the engine back by copying the bytes creation wrote
// into the same block at the same address.
#pragma once
#include <sanitizer/asan_interface.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "ffseg.h"

namespace ffseg_fuzz {

class ReusedBlock {
 public:
  ReusedBlock() = default;
  ReusedBlock(const ReusedBlock&) = delete;
  ReusedBlock& operator=(const ReusedBlock&) = delete;
  ~ReusedBlock() {
    if (base_) ASAN_UNPOISON_MEMORY_REGION(base_, cap_);
    std::free(base_);
  }

  // Returns p with p % 64 == misalign and [p, p + bytes) addressable; the rest
  // of the block is poisoned. When misalign == 0 and bytes % 64 == 0 (every
  // exact workspace size is a multiple of 64), p + bytes is the block's end,
  // so the first byte past the workspace is poisoned exactly. The contents are
  // whatever the previous input left: the engine must not depend on them.
  unsigned char* get(size_t bytes, size_t misalign) {
    const size_t want = (bytes + misalign + 127) / 64 * 64;
    if (want > cap_) {
      if (base_) ASAN_UNPOISON_MEMORY_REGION(base_, cap_);
      std::free(base_);
      base_ = nullptr;
      cap_ = want > 2 * cap_ ? want : 2 * cap_;
      void* m = nullptr;
      if (posix_memalign(&m, 64, cap_) != 0) std::abort();
      base_ = static_cast<unsigned char*>(m);
      ASAN_POISON_MEMORY_REGION(base_, cap_);
      open_ = nullptr;
      open_bytes_ = 0;
    }
    const size_t off = (cap_ - (bytes + misalign)) & ~size_t(63);
    unsigned char* p = base_ + off + misalign;
    // Re-poisoning the whole block per input (a shadow memset of cap / 8
    // bytes, twice) was 2-3% of fuzz_volume's time: only the range handed
    // out last is closed again.
    if (p != open_ || bytes != open_bytes_) {
      if (open_) ASAN_POISON_MEMORY_REGION(open_, open_bytes_);
      ASAN_UNPOISON_MEMORY_REGION(p, bytes);
      open_ = p;
      open_bytes_ = bytes;
    }
    return p;
  }

 private:
  unsigned char* base_ = nullptr;
  size_t cap_ = 0;
  unsigned char* open_ = nullptr;  // the range left addressable by the last get()
  size_t open_bytes_ = 0;
};

class CreatedEngine {
 public:
  // The engine of configuration c (the same c at every call) in a workspace
  // of exactly ffseg_workspace_size(c) bytes, as ffseg_create leaves it, or
  // nullptr with *st set when creation fails.
  ffseg_engine* get(const ffseg_config& c, ffseg_status* st) {
    *st = FFSEG_OK;
    if (e_ == nullptr) return create(c, st);
    for (const Run& r : runs_) std::memcpy(ws_ + r.at, image_.data() + r.image_at, r.bytes);
    return e_;
  }

 private:
  struct Run {
    size_t at, bytes, image_at;
  };

  // Creates twice, into the workspace filled with 0x00 and then with 0xFF: a
  // byte creation writes holds the same value both times, one it leaves still
  // holds the fill. The 64-byte chunks holding a written byte are kept.
  ffseg_engine* create(const ffseg_config& c, ffseg_status* st) {
    size_t bytes = 0;
    *st = ffseg_workspace_size(&c, &bytes);
    if (*st != FFSEG_OK) return nullptr;
    unsigned char* ws = block_.get(bytes, 0);
    std::vector<unsigned char> zero_fill(bytes);
    ffseg_engine* e = nullptr;
    std::memset(ws, 0, bytes);
    *st = ffseg_create(&c, ws, bytes, &e);
    if (*st != FFSEG_OK) return nullptr;
    std::memcpy(zero_fill.data(), ws, bytes);
    std::memset(ws, 0xFF, bytes);
    *st = ffseg_create(&c, ws, bytes, &e);
    if (*st != FFSEG_OK) return nullptr;
    runs_.clear();
    image_.clear();
    constexpr size_t kChunk = 64;
    for (size_t at = 0; at < bytes; at += kChunk) {
      const size_t len = bytes - at < kChunk ? bytes - at : kChunk;
      bool written = false;
      for (size_t q = at; q < at + len && !written; ++q) written = ws[q] == zero_fill[q];
      if (!written) continue;
      if (!runs_.empty() && runs_.back().at + runs_.back().bytes == at) {
        runs_.back().bytes += len;
      } else {
        runs_.push_back(Run{at, len, image_.size()});
      }
      image_.insert(image_.end(), ws + at, ws + at + len);
    }
    ws_ = ws;
    e_ = e;
    return e;
  }

  ReusedBlock block_;
  unsigned char* ws_ = nullptr;
  ffseg_engine* e_ = nullptr;
  std::vector<Run> runs_;
  std::vector<unsigned char> image_;  // the written chunks, runs_ after each other
};

}  // namespace ffseg_fuzz
