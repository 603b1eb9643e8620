// The wasm twin of tests/capi/nomalloc_test.cpp's trap: this file replaces
// emscripten's malloc family (dlmalloc exports them weakly, so these strong
// definitions win; libc++'s operator new calls malloc and is counted through
// it). While armed, every call is counted; bindings/js/test/nomalloc.test.js
// arms it around create, set_volume, init_sphere, step, extract and rasterize.
#include <cstddef>
#include <cstring>
#include <emscripten/emscripten.h>

extern "C" {
void* emscripten_builtin_malloc(size_t);
void* emscripten_builtin_memalign(size_t, size_t);
void emscripten_builtin_free(void*);
void* __libc_realloc(void*, size_t);
}

namespace {
bool g_armed = false;
int g_calls = 0;
inline void note() {
  if (g_armed) ++g_calls;
}
}  // namespace

extern "C" {
void* malloc(size_t n) { note(); return emscripten_builtin_malloc(n); }
void* calloc(size_t a, size_t b) {
  note();
  if (b && a > size_t(-1) / b) return nullptr;
  void* p = emscripten_builtin_malloc(a * b);
  if (p) std::memset(p, 0, a * b);
  return p;
}
void* realloc(void* p, size_t n) { note(); return __libc_realloc(p, n); }
void free(void* p) { emscripten_builtin_free(p); }
void* memalign(size_t al, size_t n) { note(); return emscripten_builtin_memalign(al, n); }
void* aligned_alloc(size_t al, size_t n) { note(); return emscripten_builtin_memalign(al, n); }
int posix_memalign(void** out, size_t al, size_t n) {
  note();
  *out = emscripten_builtin_memalign(al, n);
  return *out ? 0 : 12;
}

// on != 0 arms the trap with a zero count; 0 disarms it (the count stays).
EMSCRIPTEN_KEEPALIVE void ffseg_trap_arm(int on) {
  if (on) g_calls = 0;
  g_armed = on != 0;
}
EMSCRIPTEN_KEEPALIVE int ffseg_trap_calls(void) { return g_calls; }

// Allocates twice (malloc, then operator new) and frees both: armed, the
// count must rise by 2, which shows the trap sees what the engine would do.
EMSCRIPTEN_KEEPALIVE int ffseg_trap_probe(void) {
  void* volatile p = malloc(16);
  free(p);
  int* volatile q = new int(3);
  delete q;
  return g_calls;
}
}
