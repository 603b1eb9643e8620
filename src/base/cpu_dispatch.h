// Which vector kernel each family of kernels runs, chosen once per engine
// (Engine::create asks the CPU through detect(), the one place that does)
// and handed to the objects that run kernels when the workspace is laid out.
// Nothing is chosen per call or held process-wide, so engines on different
// threads never share dispatch state. Every kernel gives the bits of its
// portable version (the tests compare each with it; `make check-portable`
// builds the portable code alone), so the choice changes speed only.
#pragma once
#include <cstdint>

namespace ffseg {

enum class Isa : uint8_t { portable = 0, sse2 = 1, avx2 = 2, avx512 = 3 };

enum class KernelFamily : uint8_t {
  smoothing = 0,  // Perona-Malik sweep: 4 lanes (portable), 8 (AVX2), 16 (AVX-512F)
  cholesky,       // envelope Cholesky tiles: portable, AVX2 + FMA, AVX-512F + AVX2 + FMA
  exp,            // exp_block: std::exp, or the AVX-512F + FMA double-double kernel
  mixture,        // E-step and adaptive binning's pass: portable, AVX-512F
  diffusion,      // displacement diffusion rounds: portable, SSE2 (two vertices at a time)
  count
};

class CpuDispatch {
 public:
  // Portable code everywhere (the reference).
  CpuDispatch() = default;
  // The widest kernel of every family that this CPU runs (portable in
  // FFSEG_PORTABLE builds and off x86).
  static CpuDispatch detect();
  // Whether this build and CPU can run kernel k of family f.
  static bool supports(KernelFamily f, Isa k);
  static const char* name(Isa k);

  Isa kernel(KernelFamily f) const { return isa_[int(f)]; }

 private:
  friend struct CpuDispatchTesting;
  Isa isa_[int(KernelFamily::count)] = {};
};

}  // namespace ffseg
