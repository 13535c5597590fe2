#!/usr/bin/env bash
# The installed library as a consumer gets it (ctest `install`, docs/cpp.md "Installing"):
#
#   cpp/tests/install_test.sh <repo>
#
# Works in a new temporary directory outside the repository, removed when the test passes (kept,
# and named, when it fails).
# 1. installs into <tmp>/staged (cpp/cmake/install.cmake, what `make install` runs), then moves the
#    prefix to <tmp>/moved;
# 2. checks that no installed file names the repository or cargo's target directory, and that every
#    run-path is $ORIGIN-relative;
# 3. renders a USD stage with the moved bin/raysplat;
# 4. builds cpp/tests/install/consumer.cpp with find_package(raysplat) (shared and static library,
#    each also with AddressSanitizer) and with pkg-config (raysplat.pc, raysplat-static.pc), each
#    program also linking the system's OpenEXR 3.1 and zlib;
# 5. runs them (USD load, method auto, EXR written and read back by the system's OpenEXR; one
#    denoises with the private Open Image Denoise when the build has it) and checks with ldd and
#    the programs' own dladdr that zlib and OpenEXR 3.1 come from the system, nothing from the
#    repository, and only raysplat's private libraries from the prefix.
#
# Needs a Python with usd-core: $RAYSPLAT_PYTHON (make test sets it to .venv's).
set -euo pipefail
ROOT=$(cd "$1" && pwd)
WORK=$(mktemp -d "${TMPDIR:-/tmp}/raysplat-install-test.XXXXXX")
trap 'echo "install test: work directory kept: $WORK" >&2' ERR
TARGET=${RAYSPLAT_TARGET_DIR:-${CARGO_TARGET_DIR:-$ROOT/target}}
TARGET=$(cd "$TARGET" && pwd)
CXX=${CXX:-c++}
SCENE=$ROOT/scenes/cornell-box.usda
: "${RAYSPLAT_PYTHON:?install_test.sh needs RAYSPLAT_PYTHON, a Python with usd-core (make setup makes .venv)}"

fail() { echo "FAIL: $* (work directory kept: $WORK)" >&2; exit 1; }
step() { echo "== $* ($SECONDS s)"; }

export RAYSPLAT_CACHE_DIR=$WORK/usd-cache

step "install into $WORK/staged, move to $WORK/moved"
cmake -DPREFIX="$WORK/staged" -P "$ROOT/cpp/cmake/install.cmake" | grep -v "^-- Set runtime path"
mv "$WORK/staged" "$WORK/moved"
P=$WORK/moved
echo "install size: $(du -sh "$P" | cut -f1) (lib/raysplat $(du -sh "$P/lib/raysplat" | cut -f1)," \
     "libraysplat.a $(du -sh "$P/lib/libraysplat.a" | cut -f1), libraysplat.so $(du -shL "$P/lib/libraysplat.so" | cut -f1))"
for f in bin/raysplat lib/libraysplat.so lib/libraysplat.a include/raysplat/raysplat.hpp \
         include/raysplat/progress.hpp include/raysplat/rust/cxx.h include/raysplat/src/ffi/bridge.rs.h \
         lib/cmake/raysplat/raysplatConfig.cmake lib/cmake/raysplat/raysplatConfigVersion.cmake \
         lib/pkgconfig/raysplat.pc lib/pkgconfig/raysplat-static.pc lib/raysplat/libOpenEXR-3_0.so \
         share/raysplat/requirements.txt; do
  [ -e "$P/$f" ] || fail "$f was not installed"
done
[ -z "$(ls "$P"/lib/raysplat | grep -E '^lib(z|tbb)\.so')" ] || fail "zlib or TBB installed privately: $(ls "$P"/lib/raysplat)"

step "nothing installed names $ROOT or $TARGET; run-paths are \$ORIGIN-relative"
if grep -rlF -e "$ROOT" -e "$TARGET" "$P"; then fail "the files above name the build tree"; fi
while IFS= read -r f; do
  if [ "$(head -c 4 "$f" | tail -c 3)" = ELF ]; then
    paths=$(readelf -d "$f" | sed -n 's/.*(\(RPATH\|RUNPATH\)).*\[\(.*\)\]/\2/p')
    echo "  ${f#$P/}: ${paths:-no run-path}"
    for p in ${paths//:/ }; do
      case $p in '$ORIGIN'*) ;; *) fail "$f has run-path entry $p" ;; esac
    done
  fi
done < <(find "$P" -type f \( -name '*.so*' -o -path '*/bin/*' \))
exports=$(nm -D --defined-only "$P/lib/libraysplat.so" | awk '{print $3}')
if echo "$exports" | grep -vE '^_Z(N[KRVO]*|T[ISV]N?)(4rust|8raysplat)' | grep .; then
  fail "libraysplat.so exports more than the API (above)"
fi
if echo "$exports" | grep -E '17h[0-9a-f]{16}E$' | head -3 | grep .; then fail "libraysplat.so exports Rust symbols"; fi
echo "  libraysplat.so exports $(echo "$exports" | wc -l) symbols, all of namespaces raysplat and rust (cxx)"

step "bin/raysplat renders a USD stage"
"$P/bin/raysplat" render "$SCENE" -o "$WORK/cli.exr" --resolution 32x32 --spp 4 | tail -n 1
[ -s "$WORK/cli.exr" ] || fail "bin/raysplat wrote no EXR"

step "consumers with find_package(raysplat) (shared, static, each also with AddressSanitizer)"
cmake -S "$ROOT/cpp/tests/install" -B "$WORK/consumer" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$P" -DCMAKE_CXX_COMPILER="$CXX" > "$WORK/consumer-configure.log" 2>&1 \
  || { cat "$WORK/consumer-configure.log"; fail "configuring the find_package consumer"; }
cmake --build "$WORK/consumer" -j2 > "$WORK/consumer-build.log" 2>&1 \
  || { cat "$WORK/consumer-build.log"; fail "building the find_package consumer"; }

step "consumers with pkg-config (raysplat, raysplat-static)"
export PKG_CONFIG_PATH=$P/lib/pkgconfig
"$CXX" -std=c++17 -O1 "$ROOT/cpp/tests/install/consumer.cpp" -o "$WORK/consumer_pc_shared" \
  $(pkg-config --cflags --libs raysplat OpenEXR zlib) -ldl
"$CXX" -std=c++17 -O1 "$ROOT/cpp/tests/install/consumer.cpp" -o "$WORK/consumer_pc_static" \
  $(pkg-config --cflags --libs raysplat-static OpenEXR zlib) -ldl

check_resolution() { # <program>: what ldd resolves
  local exe=$1 out
  out=$(ldd "$exe")
  echo "$out" | grep -q "not found" && { echo "$out"; fail "$exe: a library is not found"; }
  echo "$out" | grep -F "$ROOT" && fail "$exe: a library resolves into the repository"
  echo "$out" | grep -E '^\s*lib(z\.so|OpenEXR[A-Za-z]*-3_1|Imath-3_1|Iex-3_1|tbb\.so)' | grep -F "$P" \
    && fail "$exe: zlib, TBB or the system's OpenEXR resolves into raysplat's folders"
  echo "$out" | grep -E '^\s*lib(z\.so|OpenEXRCore-3_1)' | grep -q . || fail "$exe: does not link the system's zlib/OpenEXR"
  if readelf -d "$exe" | grep -E 'RPATH|RUNPATH' | grep -F "$ROOT"; then fail "$exe: run-path into the repository"; fi
  return 0
}

run() { # <name> <program> [python] [denoise]: run it, check its output
  local name=$1 exe=$2 log=$WORK/$1.log
  shift 2
  check_resolution "$exe"
  "$exe" "$SCENE" "$WORK/$name.exr" "$@" > "$log" 2>&1 || { cat "$log"; fail "$name failed"; }
  grep -E '^(zlib|OpenEXR|auto chose)' "$log" | sed "s/^/  $name: /"
  grep -E '^(zlib|OpenEXR) ' "$log" | grep -F "$P" && fail "$name: zlib/OpenEXR 3.1 loaded from raysplat's prefix"
  grep -q "^read back $WORK/$name.exr" "$log" || fail "$name: no EXR read back"
  return 0
}

step "run them (RAYSPLAT_CACHE_DIR=$RAYSPLAT_CACHE_DIR)"
run find_package_shared "$WORK/consumer/consumer_shared"
run find_package_static "$WORK/consumer/consumer_static"
# the converter's Python as the StageView field, not the environment variable; denoise "auto"
# (the private Open Image Denoise when this build has it)
python=$RAYSPLAT_PYTHON
( unset RAYSPLAT_PYTHON; run pkg_config_shared "$WORK/consumer_pc_shared" "$python" auto )
if grep -q 'denoiser: Open Image Denoise' "$WORK/pkg_config_shared.log"; then
  grep -q '^layers:.* raw' "$WORK/pkg_config_shared.log" || fail "pkg_config_shared: the build has a denoiser but did not denoise"
  echo "  pkg_config_shared: denoised with $(sed -n 's/.*denoiser: //p' "$WORK/pkg_config_shared.log")"
else
  echo "  pkg_config_shared: this build has no denoiser, not denoised"
fi
run pkg_config_static "$WORK/consumer_pc_static"

step "the find_package consumers under AddressSanitizer"
export ASAN_OPTIONS=halt_on_error=1:detect_leaks=1:detect_stack_use_after_return=1
export LSAN_OPTIONS=suppressions=$ROOT/cpp/tests/lsan.supp:print_suppressions=0
run find_package_shared_asan "$WORK/consumer/consumer_shared_asan"
run find_package_static_asan "$WORK/consumer/consumer_static_asan"

step "done: installed, moved, 6 consumers built and run"
rm -rf "$WORK"
