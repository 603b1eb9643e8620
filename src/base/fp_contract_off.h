// Include last in a file whose wide kernels must not contract a * b + c into
// an FMA (the scalar code they reproduce rounds both): GCC takes it per
// function (mark them FFSEG_NO_FMA_CONTRACT), clang for the rest of the file.
#pragma once
#if defined(__clang__)
#pragma clang fp contract(off)
#define FFSEG_NO_FMA_CONTRACT
#else
#define FFSEG_NO_FMA_CONTRACT __attribute__((optimize("fp-contract=off")))
#endif
