#!/usr/bin/env bash
# make check-abi / make abi-baseline: the shared library's ABI against the
# committed baseline abi/libffseg.so.0.abi (abidw, from a build with debug
# information; only what ffseg.h declares: the exported functions and the
# public structs, member by member, offsets in bits).
#   abi/check.sh BUILD_ABI_DIR            fail on any difference (abidiff)
#   abi/check.sh --update BUILD_ABI_DIR   rewrite the baseline; refused when the
#                                         ABI changed but the version did not
# A change to a public struct's layout or a function's signature is deliberate
# only together with a version bump (ffseg.h FFSEG_VERSION_*, CMakeLists.txt
# project VERSION, ffseg-sys's constants) and the new baseline, in one commit.
set -euo pipefail
UPDATE=0
if [ "${1:-}" = "--update" ]; then UPDATE=1; shift; fi
BUILD=$(realpath "$1")
ABI=$(cd "$(dirname "$0")" && pwd)
SRC=$(dirname "$ABI")
BASE=$ABI/libffseg.so.0.abi
LIB=$(realpath "$BUILD/libffseg.so.0")
# Locations are left out so that a comment edit in the header changes nothing.
ABIDW=(abidw --headers-dir "$SRC/include" --drop-private-types --exported-interfaces-only
       --no-corpus-path --no-comp-dir-path --no-show-locs --type-id-style hash)

fail() { echo "check-abi: FAILED: $*" >&2; exit 1; }

hv() { sed -n "s/^#define FFSEG_VERSION_$1 \([0-9]*\)$/\1/p" "$SRC/include/ffseg.h"; }
VERSION="$(hv MAJOR).$(hv MINOR).$(hv PATCH)"
CMAKE_VERSION=$(sed -n 's/^project(ffseg VERSION \([0-9.]*\).*/\1/p' "$SRC/CMakeLists.txt")
[ "$VERSION" = "$CMAKE_VERSION" ] || fail "ffseg.h says $VERSION, CMakeLists.txt $CMAKE_VERSION"
readelf --debug-dump=info "$LIB" 2>/dev/null | grep ffseg_volume > /dev/null ||
  fail "$LIB has no debug information for the public structs (build it RelWithDebInfo)"

"${ABIDW[@]}" --out-file "$BUILD/libffseg.so.0.abi" "$LIB"

if [ "$UPDATE" = 1 ]; then
  if [ -f "$BASE" ] && ! abidiff "$BASE" "$BUILD/libffseg.so.0.abi" > /dev/null &&
     [ "$(cat "$ABI/VERSION")" = "$VERSION" ]; then
    fail "the ABI changed but the version is still $VERSION: bump it first"
  fi
  cp "$BUILD/libffseg.so.0.abi" "$BASE"
  echo "$VERSION" > "$ABI/VERSION"
  echo "abi-baseline: abi/libffseg.so.0.abi written for ffseg $VERSION"
  exit 0
fi

[ -f "$BASE" ] || fail "no baseline: make abi-baseline"
[ "$(cat "$ABI/VERSION")" = "$VERSION" ] ||
  fail "the baseline is of ffseg $(cat "$ABI/VERSION"), the library is $VERSION: make abi-baseline"
# abidiff must see a planted change, or a pass means nothing: two fields of
# ffseg_volume swapped in a copy of the header, compiled into a one-function
# probe library each way, described with the same flags, must differ.
PROBE=$BUILD/abi-probe
rm -rf "$PROBE"; mkdir -p "$PROBE/real" "$PROBE/swapped"
cp "$SRC/include/ffseg.h" "$PROBE/real/"
awk '/^  uint64_t data_bytes;/ { held = $0; next }
     held != "" && /^  int64_t offset;/ { print; print held; held = ""; next } { print }' \
  "$SRC/include/ffseg.h" > "$PROBE/swapped/ffseg.h"
! cmp -s "$PROBE/real/ffseg.h" "$PROBE/swapped/ffseg.h" || fail "the probe's swap did not apply to ffseg.h"
for v in real swapped; do
  printf '#include "ffseg.h"\nFFSEG_API ffseg_status ffseg_set_volume(ffseg_engine* e, const ffseg_volume* v) { return (ffseg_status)(v->offset + (e != 0)); }\n' \
    > "$PROBE/$v/probe.c"
  cc -g -shared -fPIC -I"$PROBE/$v" "$PROBE/$v/probe.c" -o "$PROBE/$v/libprobe.so"
  abidw --headers-dir "$PROBE/$v" --drop-private-types --exported-interfaces-only --no-corpus-path \
    --no-comp-dir-path --no-show-locs --out-file "$PROBE/$v/probe.abi" "$PROBE/$v/libprobe.so"
done
if abidiff "$PROBE/real/probe.abi" "$PROBE/swapped/probe.abi" > "$PROBE/diff.txt"; then
  fail "abidiff does not see two swapped fields of ffseg_volume"
fi

echo "check-abi: libffseg.so.0 ($VERSION) against abi/libffseg.so.0.abi"
if ! abidiff "$BASE" "$BUILD/libffseg.so.0.abi" > "$BUILD/abidiff.txt"; then
  cat "$BUILD/abidiff.txt"
  fail "the ABI differs from the baseline. If that is deliberate: bump the version (ffseg.h, CMakeLists.txt, ffseg-sys), make abi-baseline, and commit both with the change"
fi
echo "check-abi: no ABI change ($(grep -c '<elf-symbol ' "$BASE") functions, $(grep -c "<class-decl name='ffseg_[a-z_]*' size-in-bits" "$BASE") structs)"
