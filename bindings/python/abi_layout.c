/* Prints the C compiler's layout of every struct in ffseg.h, one line each:
 *   STRUCT sizeof SIZE
 *   STRUCT FIELD OFFSET SIZE
 * tests/test_abi.py compares it with the ctypes mirror in ffseg/_abi.py. The
 * fields come from abi/ffseg_fields.h, the list the no-padding unit test holds
 * to the header (a field left out of it fails there), so a field appended to
 * the header needs no second edit here (the hand-written list this replaces
 * missed 0.5.0's three ffseg_step_info arrays at first). Included by path:
 * CMake gives this target only include/. */
#include <stddef.h>
#include <stdio.h>

#include "ffseg.h"
#include "../../abi/ffseg_fields.h"

#define F(T, f) printf(#T " " #f " %u %u\n", (unsigned)offsetof(T, f), (unsigned)sizeof(((T*)0)->f));
#define S(T, FIELDS) printf(#T " sizeof %u\n", (unsigned)sizeof(T)); FIELDS(F)

int main(void) {
  FFSEG_PUBLIC_STRUCTS(S)

  /* Constants the mirror repeats. */
  printf("const FFSEG_STAGE_COUNT %d\n", FFSEG_STAGE_COUNT);
  printf("const FFSEG_REPORT_OBJECTS %d\n", FFSEG_REPORT_OBJECTS);
  printf("const FFSEG_TARGET_BINARY %d\n", FFSEG_TARGET_BINARY);
  printf("const FFSEG_TARGET_INTENSITY %d\n", FFSEG_TARGET_INTENSITY);
  printf("const FFSEG_CONVERGED %d\n", FFSEG_CONVERGED);
  printf("const FFSEG_DEGENERATE %d\n", FFSEG_DEGENERATE);
  printf("const FFSEG_OBJECT_NO_BOUNDARY %u\nconst FFSEG_OBJECT_FILLS_GRID %u\n", FFSEG_OBJECT_NO_BOUNDARY,
         FFSEG_OBJECT_FILLS_GRID);
  printf("const FFSEG_OBJECT_STALLED %u\n", FFSEG_OBJECT_STALLED);
  printf("const FFSEG_U8 %d\nconst FFSEG_I16 %d\nconst FFSEG_U16 %d\n", FFSEG_U8, FFSEG_I16, FFSEG_U16);
  printf("const FFSEG_I32 %d\nconst FFSEG_F32 %d\nconst FFSEG_F64 %d\n", FFSEG_I32, FFSEG_F32, FFSEG_F64);
  return 0;
}
