// How a workspace is laid out behind the opaque handle (ffseg_capi.cpp):
//
//   [ Guard, kGuardBytes ][ the engine, Engine::workspace_bytes() ][ tail canary, kTailBytes ]
//
// The handle points at the guard (the start of the caller's workspace). Only
// the C API and tests that reach the engine's testing hooks include this.
#pragma once
#include <cstddef>
#include <cstdint>

#include "engine.h"

struct ffseg_engine;

namespace ffseg {
namespace capi {

struct Guard {
  // Bit w of map: word w of the Engine object held an address inside the
  // workspace when the engine was created (its layout table).
  static constexpr size_t kEngineWords = sizeof(Engine) / sizeof(uintptr_t);
  static constexpr size_t kMapWords = (kEngineWords + 63) / 64;
  uint64_t magic;         // kGuardMagic while the engine is live
  uint64_t engine_bytes;  // the engine's part of the workspace
  uint64_t layout;        // hash of the layout table's words
  uint64_t canary;        // hash of the guard's address and the fields above
  uint64_t map[kMapWords];
};

constexpr size_t kGuardBytes = (sizeof(Guard) + kAlign - 1) / kAlign * kAlign;
constexpr size_t kTailBytes = kAlign;  // keeps the total a multiple of 64

inline Engine* engine_of(ffseg_engine* e) {
  return reinterpret_cast<Engine*>(reinterpret_cast<unsigned char*>(e) + kGuardBytes);
}

}  // namespace capi
}  // namespace ffseg
