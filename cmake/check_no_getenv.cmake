# ctest tests_read_no_environment: fails when a file under DIR (tests/) calls
# getenv / secure_getenv, so that ffseg_tests stays only tests; experiments
# driven by environment variables belong in tools/experiments.
file(GLOB_RECURSE files "${DIR}/*.c" "${DIR}/*.cpp" "${DIR}/*.h")
set(bad "")
foreach(f ${files})
  file(STRINGS "${f}" hits REGEX "getenv[ \t]*\\(")
  if(hits)
    list(APPEND bad "${f}: ${hits}")
  endif()
endforeach()
if(bad)
  string(REPLACE ";" "\n" msg "${bad}")
  message(FATAL_ERROR "tests/ reads the environment (move it to tools/experiments):\n${msg}")
endif()
list(LENGTH files n)
message(STATUS "tests/: ${n} files, none reads the environment")
