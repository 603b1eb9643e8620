// The test hooks, in one place and out of the production interfaces: a test
// (never the C API) reaches them through these structs. The lower layers'
// hooks (they cannot include engine/) come in with their headers.
#pragma once
#include "engine.h"
#include "image_testing.h"  // ExpBlockTesting
#include "mesh_testing.h"   // TriangleScratchTesting
#include "solve_testing.h"  // EnvelopeCholeskyTesting
#include "testing_hooks.h"  // CpuDispatchTesting

namespace ffseg {

struct EngineTesting {
  // The naive variant of thesis fig. 4.10: vertices move straight towards
  // their targets; no flip or fold handling, no Laplacian solve.
  static void set_naive(Engine& e, bool on) { e.naive_ = on; }
  // The bounding regions' speed tables (bounding_region.h): kept between
  // computations while the models are the same (the engine's way), never
  // kept, or kept across model changes (a missed invalidation, so that a
  // test can show it would see one).
  enum class SpeedTables : uint8_t { kept = 0, none = 1, stale = 2 };
  static void set_speed_tables(Engine& e, SpeedTables t) { e.speed_tables_ = uint8_t(t); }
  // The kernels the engine chose at create.
  static const CpuDispatch& cpu(const Engine& e) { return e.cpu_; }
};

}  // namespace ffseg
