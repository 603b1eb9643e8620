// Compiles include/ffseg.h as C++17 with -Wall -Wextra -Werror -pedantic.
#include "ffseg.h"

int ffseg_header_check_cxx() {
  ffseg_config c{};
  c.struct_size = sizeof c;
  return static_cast<int>(c.struct_size) + FFSEG_OK;
}
