#!/usr/bin/env bash
# make coverage: clang source-based coverage of the unit tests plus a replay of
# the fuzz corpora, as line coverage per folder of src/, capi/ and tools/ and
# in total (scripts/coverage_summary.py). Builds into build-cov/ (the library,
# CLI and tests, instrumented) and build-cov-fuzz/ (the fuzz targets with
# coverage instead of sanitizers); profiles in build-cov/prof/.
set -euo pipefail
cd "$(dirname "$0")/.."
JOBS=${JOBS:-2}
B=build-cov
FB=build-cov-fuzz
PROF=$B/prof
LLVM_PROFDATA=${LLVM_PROFDATA:-llvm-profdata-14}
LLVM_COV=${LLVM_COV:-llvm-cov-14}
COV="-fprofile-instr-generate -fcoverage-mapping"

CC=clang CXX=clang++ cmake -S . -B "$B" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_C_FLAGS="$COV" -DCMAKE_CXX_FLAGS="$COV" \
  -DCMAKE_EXE_LINKER_FLAGS=-fprofile-instr-generate -DCMAKE_SHARED_LINKER_FLAGS=-fprofile-instr-generate > /dev/null
cmake --build "$B" -j "$JOBS" --target ffseg_tests ffseg_cli ffseg_nomalloc_test
CC=clang CXX=clang++ cmake -S fuzz -B "$FB" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFFSEG_FUZZ_COVERAGE=ON > /dev/null
cmake --build "$FB" -j "$JOBS"

rm -rf "$PROF" && mkdir -p "$PROF"
# The CLI runs as a child of the tests: %p keeps one profile per process.
(cd "$B" && LLVM_PROFILE_FILE="$PWD/prof/unit-%p.profraw" ./ffseg_tests > prof/unit.log 2>&1) ||
  { tail -n 30 "$PROF/unit.log"; echo "coverage: the unit tests failed"; exit 1; }
(cd "$B" && LLVM_PROFILE_FILE="$PWD/prof/nomalloc-%p.profraw" ./ffseg_nomalloc_test > prof/nomalloc.log 2>&1) ||
  { tail -n 30 "$PROF/nomalloc.log"; echo "coverage: the no-malloc test failed"; exit 1; }
objects=("$B/ffseg_tests" -object "$B/ffseg" -object "$B/ffseg_nomalloc_test")
for t in volume nifti calls nrrd metaimage; do
  LLVM_PROFILE_FILE="$PWD/$PROF/fuzz-$t-%p.profraw" "./$FB/fuzz_$t" -runs=0 fuzz/corpus/$t > "$PROF/fuzz-$t.log" 2>&1 ||
    { tail -n 30 "$PROF/fuzz-$t.log"; echo "coverage: replaying fuzz/corpus/$t failed"; exit 1; }
  objects+=(-object "$FB/fuzz_$t")
done
"$LLVM_PROFDATA" merge -sparse "$PROF"/*.profraw -o "$PROF/all.profdata"
"$LLVM_COV" export -summary-only -instr-profile="$PROF/all.profdata" "${objects[@]}" > "$PROF/summary.json"
python3 scripts/coverage_summary.py "$PROF/summary.json" "$PWD"
