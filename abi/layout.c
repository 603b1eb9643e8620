/* layout.c - prints what the C compiler makes of every public struct of ffseg.h,
 * one line per struct and per field:
 *     struct ffseg_volume 256
 *     field ffseg_volume dims 40 24        (offset, size in bytes)
 * The Rust and C# bindings' tests compare their own declarations with this
 * output, so a binding cannot silently drift from the header. Exits 1 (after
 * printing) if a struct has a gap between fields or tail padding. */
#include <stddef.h>
#include <stdio.h>

#include "ffseg.h"
#include "ffseg_fields.h"

static int gaps = 0;
static size_t next_offset = 0;

static void field(const char* s, const char* f, size_t off, size_t size) {
  printf("field %s %s %zu %zu\n", s, f, off, size);
  if (off != next_offset) {
    fprintf(stderr, "layout: %s.%s at %zu, previous field ends at %zu (implicit padding)\n", s, f, off,
            next_offset);
    gaps = 1;
  }
  next_offset = off + size;
}

static void end_struct(const char* s, size_t size) {
  printf("struct %s %zu\n", s, size);
  if (next_offset != size) {
    fprintf(stderr, "layout: %s has %zu bytes of tail padding\n", s, size - next_offset);
    gaps = 1;
  }
  next_offset = 0;
}

#define FFSEG_PRINT_FIELD(S, F) field(#S, #F, offsetof(S, F), sizeof(((S*)0)->F));
#define FFSEG_PRINT_STRUCT(S, FIELDS) FIELDS(FFSEG_PRINT_FIELD) end_struct(#S, sizeof(S));

int main(void) {
  FFSEG_PUBLIC_STRUCTS(FFSEG_PRINT_STRUCT)
  return gaps;
}
