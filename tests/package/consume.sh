#!/usr/bin/env bash
# The installed package (docs/library.md), end to end: install a build tree into a folder of its
# own, check what was installed (the public header alone, no flag or path of this machine or this
# source tree), then build examples/consumer against it three ways (CMake with the shared library,
# CMake with the static one, pkg-config) and run each. ctest runs it (tests/CMakeLists.txt:
# Package.InstallAndConsume) as
#   consume.sh BUILD_DIR WORK_DIR SOURCE_DIR LIBDIR CXX GENERATOR MAKE_PROGRAM
set -euo pipefail

build=$1 work=$2 source=$3 libdir=$4 cxx=$5 generator=$6 make_program=$7
prefix=$work/prefix
example=$source/examples/consumer
start=$SECONDS

step() { echo "== [$((SECONDS - start)) s] $*"; }
fail() {
  echo "FAILED: $*" >&2
  exit 1
}

rm -rf "$work"
mkdir -p "$work"

# The libraries as they stand (a no-op after `make test`'s build), then the install.
step "build the libraries"
cmake --build "$build" -j 2 --target penumbra penumbra_shared penumbra_cli penumbra_view \
  >"$work/build.log" 2>&1 ||
  { cat "$work/build.log"; fail "the libraries do not build"; }
step "install into $prefix"
cmake --install "$build" --prefix "$prefix" >"$work/install.log"

step "check the install tree"
for f in include/penumbra/penumbra.h "$libdir/libpenumbra.a" "$libdir/libpenumbra.so" \
  "$libdir/pkgconfig/penumbra.pc" "$libdir/cmake/Penumbra/PenumbraConfig.cmake" \
  "$libdir/cmake/Penumbra/PenumbraConfigVersion.cmake" \
  "$libdir/cmake/Penumbra/PenumbraTargets.cmake" \
  "$libdir/cmake/Penumbra/PenumbraStaticTargets.cmake"; do
  [[ -e $prefix/$f ]] || fail "$f is not installed"
done
# The CLI runs from the install tree and reports the package's version.
version_line=$("$prefix/bin/penumbra" --version)
[[ $version_line == "penumbra $(sed -n 's/^Version: //p' "$prefix/$libdir/pkgconfig/penumbra.pc")" ]] ||
  fail "the installed CLI says '$version_line'"
[[ -x $prefix/bin/penumbra-view ]] || fail "the viewer is not installed beside the CLI"
headers=$(cd "$prefix/include" && find . -type f | sort | tr '\n' ' ')
# penumbra.h, and with MPI in the build penumbra_mpi.h (an MPI_Comm to the API's communicator).
[[ $headers == "./penumbra/penumbra.h " || $headers == "./penumbra/penumbra.h ./penumbra/penumbra_mpi.h " ]] ||
  fail "headers other than penumbra.h (and penumbra_mpi.h) installed: $headers"
if [[ -f $prefix/include/penumbra/penumbra_mpi.h ]] &&
  grep -E '^\s*#\s*include' "$prefix/include/penumbra/penumbra_mpi.h" |
  grep -Ev '^\s*#\s*include\s*<(mpi\.h|penumbra/penumbra\.h)>'; then
  fail "penumbra_mpi.h includes something other than mpi.h and penumbra.h"
fi
# Standard headers only: <name> without a '.' or a '/'.
if grep -E '^\s*#\s*include' "$prefix/include/penumbra/penumbra.h" |
  grep -Ev '^\s*#\s*include\s*<[a-z_]+>'; then
  fail "penumbra.h includes something other than the standard library"
fi
# Nothing of the build machine or of the internals: no code-generation flags, no internal
# definitions, no path into the source tree.
leaks='(^|[^[:alnum:]_])-m(arch|tune|avx|sse|fma|bmi|gfni|f16c|popcnt|lzcnt)|-ffp-contract'
leaks+='|GLM_[A-Z_]+|SPDLOG_[A-Z_]+'
installed_meta=("$prefix/$libdir/cmake/Penumbra/"*.cmake "$prefix/$libdir/pkgconfig/penumbra.pc")
if grep -En -- "$leaks" "${installed_meta[@]}"; then
  fail "the package config or penumbra.pc carries a machine flag or an internal definition"
fi
if grep -Fn -- "$source/src" "${installed_meta[@]}"; then
  fail "the package config or penumbra.pc names the source tree"
fi
if readelf -d "$prefix/$libdir/libpenumbra.so" | grep -q TEXTREL; then
  fail "libpenumbra.so has text relocations (objects not position-independent)"
fi
readelf -d "$prefix/$libdir/libpenumbra.so" | grep -q 'SONAME.*libpenumbra\.so\.[0-9]' ||
  fail "libpenumbra.so has no versioned SONAME"
if ldd "$prefix/$libdir/libpenumbra.so" | grep 'not found'; then
  fail "libpenumbra.so needs a library the loader does not find"
fi

export PKG_CONFIG_PATH=$prefix/$libdir/pkgconfig
cflags=$(pkg-config --cflags penumbra)
[[ $cflags =~ ^-I[^[:space:]]+[[:space:]]*$ ]] || fail "pkg-config --cflags penumbra: '$cflags'"

# CMake, the shared library and then the static one. The compile lines must not reach into the
# source tree's headers.
for variant in shared static; do
  step "consumer with CMake, $variant"
  static=OFF
  [[ $variant == static ]] && static=ON
  cmake -S "$example" -B "$work/$variant" -G "$generator" -DCMAKE_MAKE_PROGRAM="$make_program" \
    -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$prefix" \
    -DPENUMBRA_EXAMPLE_STATIC=$static >"$work/$variant-configure.log" 2>&1 ||
    { cat "$work/$variant-configure.log"; fail "configuring the consumer ($variant)"; }
  grep -F "Penumbra 0.1" "$work/$variant-configure.log" | grep -qF "$prefix/" ||
    fail "the consumer ($variant) did not find the package in $prefix"
  cmake --build "$work/$variant" -j 2 -v >"$work/$variant-build.log" 2>&1 ||
    { cat "$work/$variant-build.log"; fail "building the consumer ($variant)"; }
  if grep -E -- "-I *$source/src|-isystem *$source/src|-march|-ffp-contract" \
    "$work/$variant-build.log"; then
    fail "the consumer ($variant) was compiled with the source tree's headers or flags"
  fi
  if [[ $variant == static ]] && ldd "$work/$variant/consumer" | grep -q libpenumbra; then
    fail "the static consumer loads libpenumbra.so"
  fi
  "$work/$variant/consumer" || fail "the consumer ($variant) failed its checks"
done

# pkg-config alone.
step "consumer with pkg-config"
mkdir -p "$work/pkg-config"
# shellcheck disable=SC2046  # pkg-config's output is meant to split into arguments
"$cxx" -std=c++20 -O2 -DPENUMBRA_EXPECTED_VERSION="\"$(pkg-config --modversion penumbra)\"" \
  "$example/main.cpp" -o "$work/pkg-config/consumer" $(pkg-config --cflags --libs penumbra) \
  -Wl,-rpath,"$(pkg-config --variable=libdir penumbra)" ||
  fail "building the consumer with pkg-config"
"$work/pkg-config/consumer" || fail "the consumer (pkg-config) failed its checks"

step "package test passed"
