/* Compiles include/ffseg.h as C (c89/c99/c11) with -Wall -Wextra -Werror -pedantic. */
#include "ffseg.h"

int ffseg_header_check(void);
int ffseg_header_check(void) {
  ffseg_config c;
  ffseg_params p;
  ffseg_volume v;
  ffseg_step_info s;
  c.struct_size = (uint32_t)sizeof c;
  p.struct_size = (uint32_t)sizeof p;
  v.struct_size = (uint32_t)sizeof v;
  s.struct_size = (uint32_t)sizeof s;
  return (int)(c.struct_size + p.struct_size + v.struct_size + s.struct_size) + FFSEG_CONVERGED;
}
