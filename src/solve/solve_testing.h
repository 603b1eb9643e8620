// Test hooks of the solve layer (engine/testing.h gathers every layer's).
#pragma once
#include "envelope_cholesky.h"
#include "testing_hooks.h"

namespace ffseg {

struct EnvelopeCholeskyTesting {
  // c runs tile kernel k from now on (unchanged when this CPU cannot), so one
  // assembled system can be factored by every kernel in turn.
  static void use(EnvelopeCholesky& c, Isa k) { c.cpu_ = CpuDispatchTesting::with(c.cpu_, KernelFamily::cholesky, k); }
};

}  // namespace ffseg
