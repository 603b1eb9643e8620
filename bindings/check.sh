#!/usr/bin/env bash
# make check-bindings: install ffseg into a temporary prefix and build and run,
# against that prefix only, what a vendor would: the C examples through
# pkg-config (shared and static), the C and C++ examples through
# find_package(ffseg), the Rust crates' tests and examples, the C# wrapper's
# tests and examples. Usage: bindings/check.sh BUILD_DIR WORK_DIR
set -euo pipefail
BUILD=$(realpath "$1")
WORK=$(realpath -m "$2")
SRC=$(cd "$(dirname "$0")/.." && pwd)
P=$WORK/prefix
CC=${CC:-cc}
# Debian's toolchain when it is there (rustc 1.63, the version the crates promise),
# whatever else may come first on PATH.
CARGO=${CARGO:-$(command -v /usr/bin/cargo || command -v cargo)}
export RUSTC=${RUSTC:-$(command -v /usr/bin/rustc || command -v rustc)}
export RUSTDOC=${RUSTDOC:-$(command -v /usr/bin/rustdoc || command -v rustdoc)}

step() { printf '\n== check-bindings: %s\n' "$*"; }
fail() { echo "check-bindings: FAILED: $*" >&2; exit 1; }

rm -rf "$WORK"
mkdir -p "$WORK"
step "install into $P"
cmake --install "$BUILD" --prefix "$P" > "$WORK/install.log"
for f in include/ffseg.h lib/libffseg.a lib/libffseg.so.0 lib/pkgconfig/ffseg.pc \
         lib/cmake/ffseg/ffseg-config.cmake lib/cmake/ffseg/ffseg-config-version.cmake; do
  [ -e "$P/$f" ] || fail "$f not installed"
done
# The header stands alone: no path into the source tree or shared docs.
if grep -nE 'shared/|src/[a-z_]+\.h' "$P/include/ffseg.h"; then fail "the installed header refers outside itself"; fi

export PKG_CONFIG_PATH=$P/lib/pkgconfig
VERSION=$(pkg-config --modversion ffseg)
step "pkg-config: ffseg $VERSION"
[ "$VERSION" = "$(sed -n 's/^project(ffseg VERSION \([0-9.]*\).*/\1/p' "$SRC/CMakeLists.txt")" ] ||
  fail "ffseg.pc says $VERSION"
mkdir -p "$WORK/pc"
for ex in minimal grow; do
  # shellcheck disable=SC2046
  $CC -std=c99 -Wall -Wextra -Werror -pedantic "$SRC/examples/$ex.c" -o "$WORK/pc/$ex" \
    $(pkg-config --cflags --libs ffseg)
  LD_LIBRARY_PATH=$P/lib "$WORK/pc/$ex"
done
# The archive, as `pkg-config --static` describes it: Libs.private must bring
# the C++ runtime. First without it, which must fail to link, so the check can fail.
STATIC_LIBS=$(pkg-config --static --libs ffseg | sed 's/-lffseg/-l:libffseg.a/')
# shellcheck disable=SC2046
if $CC "$SRC/examples/grow.c" -o "$WORK/pc/grow_nolibsprivate" $(pkg-config --cflags ffseg) \
     -L"$P/lib" -l:libffseg.a 2> "$WORK/pc/nolibsprivate.log"; then
  fail "linking libffseg.a without Libs.private succeeded: is it still C++ inside?"
fi
# shellcheck disable=SC2086
$CC -std=c99 "$SRC/examples/grow.c" -o "$WORK/pc/grow_static" $(pkg-config --cflags ffseg) $STATIC_LIBS
if ldd "$WORK/pc/grow_static" | grep libffseg > /dev/null; then fail "grow_static still needs libffseg.so"; fi
"$WORK/pc/grow_static"

step "CMake: find_package(ffseg 0.1) and ffseg::ffseg / ffseg::ffseg_static"
cmake -S "$SRC/examples" -B "$WORK/cmake" -DCMAKE_PREFIX_PATH="$P" -DCMAKE_BUILD_TYPE=Release > "$WORK/cmake.log"
cmake --build "$WORK/cmake" -j 2 > "$WORK/cmake-build.log" || { cat "$WORK/cmake-build.log"; fail "CMake consumer build"; }
(cd "$WORK/cmake" && ctest --output-on-failure)
# SameMajorVersion: a request for another major version must not be satisfied.
mkdir -p "$WORK/cmake-major"
printf 'cmake_minimum_required(VERSION 3.16)\nproject(m C)\nfind_package(ffseg 1.0 REQUIRED)\n' > "$WORK/cmake-major/CMakeLists.txt"
if cmake -S "$WORK/cmake-major" -B "$WORK/cmake-major/b" -DCMAKE_PREFIX_PATH="$P" > "$WORK/cmake-major.log" 2>&1; then
  fail "find_package(ffseg 1.0) accepted version $VERSION"
fi

step "Rust: ffseg-sys and ffseg ($("$RUSTC" --version))"
export LD_LIBRARY_PATH=$P/lib
(cd "$SRC/bindings/rust" && "$CARGO" test --offline --target-dir "$WORK/cargo")
step "Rust examples"
(cd "$SRC/examples/rust" && "$CARGO" build --offline --release --target-dir "$WORK/cargo-examples" -q)
for ex in roundtrip grow; do "$WORK/cargo-examples/release/$ex"; done
unset LD_LIBRARY_PATH
# build.rs's other route: no pkg-config, FFSEG_LIB_DIR, and the archive.
step "Rust examples through FFSEG_LIB_DIR, FFSEG_STATIC=1"
(cd "$SRC/examples/rust" && env -u PKG_CONFIG_PATH FFSEG_LIB_DIR="$P/lib" FFSEG_STATIC=1 \
   "$CARGO" build --offline --release --target-dir "$WORK/cargo-static" -q)
if ldd "$WORK/cargo-static/release/grow" | grep libffseg > /dev/null; then fail "FFSEG_STATIC=1 still links libffseg.so"; fi
"$WORK/cargo-static/release/grow"

step "C#: Ffseg.dll under $(mono --version | head -n 1 | cut -d'(' -f1)"
CS=$WORK/csharp
mkdir -p "$CS/runtime"
# Only the runtime files, as a runtime package installs them: the soname and
# the file it points to, no libffseg.so development link.
cp -a "$P"/lib/libffseg.so.0* "$CS/runtime/"
[ ! -e "$CS/runtime/libffseg.so" ] || fail "runtime directory holds the development link"
mcs -unsafe -warnaserror -target:library -out:"$CS/Ffseg.dll" "$SRC/bindings/csharp/Ffseg.cs"
mcs -unsafe -warnaserror -r:"$CS/Ffseg.dll" -out:"$CS/Tests.exe" "$SRC/bindings/csharp/tests/Tests.cs"
$CC -std=c99 -I"$P/include" -I"$SRC/abi" "$SRC/abi/layout.c" -o "$CS/layout"
"$CS/layout" > "$CS/layout.txt"
(cd "$CS" && LD_LIBRARY_PATH=$CS/runtime mono Tests.exe layout.txt)
step "C# examples"
for ex in Roundtrip Grow; do
  mcs -warnaserror -r:"$CS/Ffseg.dll" -out:"$CS/$ex.exe" "$SRC/examples/csharp/$ex.cs"
  (cd "$CS" && LD_LIBRARY_PATH=$CS/runtime mono "$ex.exe")
done

echo
echo "check-bindings: all passed"
