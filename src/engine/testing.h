// The engine's test hooks, in one place and out of its public interface: a
// test (never the C API) reaches them through this struct.
#pragma once
#include "engine.h"

namespace ffseg {

struct EngineTesting {
  // The naive variant of thesis fig. 4.10: vertices move straight towards
  // their targets; no flip or fold handling, no Laplacian solve.
  static void set_naive(Engine& e, bool on) { e.naive_ = on; }
};

}  // namespace ffseg
