# A stop-gap for a 64-bit assumption in capi/ (reported to the engine's owner):
# the workspace guard hashes the Engine object as 8-byte words and records the
# words that held a workspace address at create. On wasm32 a pointer is 4
# bytes, so such a "word" is a pointer glued to its neighbour field; when the
# neighbour changes during a run, the hash changes and every later call reports
# "workspace damaged: the engine's layout table was overwritten". Scanning
# pointer-sized words is the fix. Until capi/ has it, the wasm build compiles
# copies of capi/ with exactly these replacements; once a replacement no longer
# finds its text (capi/ changed), the originals are used as they are, and
# bindings/js/test catches a guard that still misfires.
function(ffseg_capi_for_wasm32 out_sources out_include)
  set(dir ${CMAKE_BINARY_DIR}/capi-wasm32)
  file(MAKE_DIRECTORY ${dir})
  file(READ ${FFSEG_ROOT}/capi/capi_internal.h h)
  file(READ ${FFSEG_ROOT}/capi/ffseg_capi.cpp c)
  set(h_old "static constexpr size_t kMapWords = (sizeof(Engine) / 8 + 63) / 64;")
  set(h_new "static constexpr size_t kMapWords = (sizeof(Engine) / sizeof(uintptr_t) + 63) / 64;")
  set(c_old1 "  uint64_t v;\n  std::memcpy(&v, static_cast<const unsigned char*>(base) + 8 * w, 8);")
  set(c_new1 "  uintptr_t v;\n  std::memcpy(&v, static_cast<const unsigned char*>(base) + sizeof v * w, sizeof v);")
  set(c_old2 "for (size_t w = 0; w < sizeof(Engine) / 8; ++w) {")
  set(c_new2 "for (size_t w = 0; w < sizeof(Engine) / sizeof(uintptr_t); ++w) {")
  string(FIND "${h}" "${h_old}" f0)
  string(FIND "${c}" "${c_old1}" f1)
  string(FIND "${c}" "${c_old2}" f2)
  file(GLOB capi_sources ${FFSEG_ROOT}/capi/*.cpp)
  list(LENGTH capi_sources n)
  if(f0 EQUAL -1 OR f1 EQUAL -1 OR f2 EQUAL -1 OR NOT n EQUAL 1)
    message(STATUS "capi/: the wasm32 guard patch does not apply; compiling capi/ as it is")
    set(${out_sources} ${capi_sources} PARENT_SCOPE)
    set(${out_include} "" PARENT_SCOPE)
    return()
  endif()
  string(REPLACE "${h_old}" "${h_new}" h "${h}")
  string(REPLACE "${c_old1}" "${c_new1}" c "${c}")
  string(REPLACE "${c_old2}" "${c_new2}" c "${c}")
  # configure-time copies: rewritten only when their text changes
  file(CONFIGURE OUTPUT ${dir}/capi_internal.h CONTENT "${h}" @ONLY)
  file(CONFIGURE OUTPUT ${dir}/ffseg_capi.cpp CONTENT "${c}" @ONLY)
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS
               ${FFSEG_ROOT}/capi/capi_internal.h ${FFSEG_ROOT}/capi/ffseg_capi.cpp)
  message(STATUS "capi/: compiled with the wasm32 guard patch (wasm/capi_wasm32.cmake)")
  set(${out_sources} ${dir}/ffseg_capi.cpp PARENT_SCOPE)
  set(${out_include} ${dir} PARENT_SCOPE)
endfunction()
