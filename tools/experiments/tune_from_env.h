#pragma once
// The experiments' parameter knobs: the environment variables FFSEG_SIGF,
// FFSEG_GAMMA, FFSEG_SR, FFSEG_ALPHA, FFSEG_SMI, FFSEG_NB, FFSEG_DIFF, FFSEG_LL,
// FFSEG_LU, FFSEG_LP, FFSEG_TAU, FFSEG_CONV, FFSEG_PVS replace the defaults
// (given as a StructureRunOptions::tune). It lives here, not in tests/support,
// because nothing ffseg_tests links may read the environment.

#include "ffseg.h"

namespace ffseg_experiments {

void tune_from_env(ffseg_params& p);

}  // namespace ffseg_experiments
