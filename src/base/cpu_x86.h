// FFSEG_X86: 1 when the x86 vector kernels are compiled (x86 with GCC or
// clang; each is chosen at run time with __builtin_cpu_supports), 0 on other
// CPUs and when FFSEG_PORTABLE is defined. With 0 only the portable code is
// built; every kernel gives the same bits as its portable counterpart, which
// the portable build (`make check-portable`) tests.
#pragma once
#if (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__) && !defined(FFSEG_PORTABLE)
#define FFSEG_X86 1
#else
#define FFSEG_X86 0
#endif
