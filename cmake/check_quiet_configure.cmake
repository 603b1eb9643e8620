# ctest quiet_configure: configures the project into a fresh directory and
# fails on any warning in CMake's output (a third-party package's config file
# that names files it did not install warns once per file: Debian's
# GDCMTargets.cmake names ten GDCM programs of another package).
set(dir "${BUILD}/quiet-configure-check")
file(REMOVE_RECURSE "${dir}")
execute_process(COMMAND "${CMAKE_COMMAND}" -S "${SRC}" -B "${dir}" -DCMAKE_BUILD_TYPE=Release
                OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
file(REMOVE_RECURSE "${dir}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "configuring failed (${rc}):\n${out}\n${err}")
endif()
string(REGEX MATCHALL "[^\n]*([Ww]arning|does not exist)[^\n]*" hits "${out}\n${err}")
if(hits)
  string(REPLACE ";" "\n" msg "${hits}")
  message(FATAL_ERROR "configuring printed warnings:\n${msg}")
endif()
message(STATUS "a fresh configure printed no warning")
