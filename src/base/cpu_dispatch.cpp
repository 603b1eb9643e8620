#include "cpu_dispatch.h"

#include <initializer_list>

#include "cpu_x86.h"

namespace ffseg {

bool CpuDispatch::supports(KernelFamily f, Isa k) {
  if (k == Isa::portable) return true;
#if FFSEG_X86
  switch (f) {
    case KernelFamily::smoothing:
      return (k == Isa::avx2 && __builtin_cpu_supports("avx2")) ||
             (k == Isa::avx512 && __builtin_cpu_supports("avx512f"));
    case KernelFamily::cholesky:
      return (k == Isa::avx2 && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) ||
             (k == Isa::avx512 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx2") &&
              __builtin_cpu_supports("fma"));
    case KernelFamily::exp:
      return k == Isa::avx512 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("fma");
    case KernelFamily::mixture:
      return k == Isa::avx512 && __builtin_cpu_supports("avx512f");
    case KernelFamily::diffusion:
#if defined(__SSE2__)
      return k == Isa::sse2;
#else
      return false;
#endif
    default:
      return false;
  }
#else
  (void)f;
  return false;
#endif
}

CpuDispatch CpuDispatch::detect() {
  CpuDispatch d;
  for (int f = 0; f < int(KernelFamily::count); ++f)
    for (Isa k : {Isa::avx512, Isa::avx2, Isa::sse2})
      if (supports(KernelFamily(f), k)) {
        d.isa_[f] = k;
        break;
      }
  return d;
}

const char* CpuDispatch::name(Isa k) {
  switch (k) {
    case Isa::sse2: return "sse2";
    case Isa::avx2: return "avx2";
    case Isa::avx512: return "avx512";
    default: return "portable";
  }
}

}  // namespace ffseg
