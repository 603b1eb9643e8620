// exp over a block of doubles, returning what std::exp returns, faster.
//
// The E-step of EM (mixture_em.cpp) spends most of its time in exp. A
// vector kernel (AVX-512F with FMA, chosen at run time) evaluates exp(x) in
// double-double arithmetic (relative error below 2^-63): reduction
// x = k ln2/16 + r with a three-part ln2/16, a degree-9 polynomial for
// exp(r) - 1 - r on |r| <= ln2/32, a table of 2^(j/16) as double-doubles
// (built once, Taylor series in double-double; read with register permutes),
// then y = hi + lo with |lo| <= ulp(hi)/2, so hi is exp(x) correctly rounded
// unless x lies within the error bound of a rounding midpoint.
//
// Certification: hi is taken only when |lo| <= 0.48 ulp on its side, i.e. the
// exact value lies at least 0.02 ulp away from the midpoint between hi and
// its neighbour. Any exp whose error is below 0.51 ulp - glibc's bound for its
// exp, documented with the implementation - then returns hi as well. Every
// other lane (about 4%: within 0.02 ulp of a midpoint, x outside
// (-670, 709), NaN) calls std::exp. So results are std::exp's bit for bit on
// such a libm; tests/image/test_intensity.cpp checks it on tens of millions of
// arguments. Without AVX-512F every value goes to std::exp.
#pragma once
#include <cstdint>

#include "cpu_dispatch.h"

namespace ffseg {

// v[t] = std::exp(v[t]) for t < n; the vector kernel when cpu's exp kernel
// is AVX-512.
void exp_block(const CpuDispatch& cpu, double* v, uint32_t n);
// The same, with the zeros (exp(0) = 1) packed out before evaluation.
void exp_block_nonzero(const CpuDispatch& cpu, double* v, uint32_t n);

}  // namespace ffseg
