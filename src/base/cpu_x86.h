// FFSEG_X86: 1 when the x86 vector kernels (the *_x86.cpp files) are
// compiled (x86 with GCC or clang; the engine's CpuDispatch picks among them
// at create), 0 on other CPUs and when FFSEG_PORTABLE is defined. With 0 the
// *_x86.cpp files compile to nothing and only the portable code is built;
// every kernel gives the same bits as its portable counterpart, which the
// portable build (`make check-portable`) tests.
#pragma once
#if (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__) && !defined(FFSEG_PORTABLE)
#define FFSEG_X86 1
#else
#define FFSEG_X86 0
#endif
