#!/usr/bin/env bash
# Install what raysplat needs, idempotently: Debian packages (Embree 3, libclang for bindgen, cmake
# and g++ for OpenEXR and the C++ API, OpenEXR tools for independent checks, GNU time for the
# hostile-input battery's peak memory, munge and Slurm's slurmctld, slurmd and clients for the
# farm's test on a one-node cluster), a Python venv in .venv with Pixar's usd-core, the
# MaterialX package (the converter reads MaterialX looks with it) and numpy (its loops over large
# meshes), and, optionally, Intel Open Image Denoise from the pyoidn wheel (its libraries; the build
# links them when present) and Embree 4 from the embreex wheel (for `--features embree4`). Safe to
# run any number of times; does nothing when all is present.
set -euo pipefail
cd "$(dirname "$0")/.."

# (libopenexr-dev and zlib1g-dev: the install test's consumer links the system's OpenEXR and zlib
# next to raysplat's own, cpp/tests/install_test.sh.)
APT_PACKAGES=(libembree-dev libclang-dev clang cmake g++ pkg-config python3 python3-venv openexr fonts-dejavu-core libopenexr-dev zlib1g-dev time munge slurmctld slurmd slurm-client)
# The converter's requirement, python/requirements.txt (usd-core==<version>).
USD_CORE_VERSION="${USD_CORE_VERSION:-$(sed -n 's/^usd-core==//p' python/requirements.txt)}"
MATERIALX_VERSION="${MATERIALX_VERSION:-1.39.5}"
# The pyoidn wheel carries libOpenImageDenoise.so.2.5.1 with its CPU device, weights and TBB.
# PYOIDN_VERSION=none skips it (the renderer then builds without the denoiser).
PYOIDN_VERSION="${PYOIDN_VERSION:-2.5.1.0}"
# The embreex wheel carries libembree4 (4.4) with its TBB, which `cargo build --features embree4`
# links (build.rs, `embree4_link`). EMBREEX_VERSION=none skips it (the default build uses Debian's
# Embree 3 and does not need it).
EMBREEX_VERSION="${EMBREEX_VERSION:-4.4.0.post1}"
# numpy: the converter's loops over large meshes (it falls back to pure Python without it)
NUMPY_VERSION="${NUMPY_VERSION:-2.4.6}"

missing=()
for p in "${APT_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing Debian packages: ${missing[*]}"
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -qq
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}"
fi

if ! command -v cargo >/dev/null 2>&1; then
  echo "setup: cargo is not installed; install a Rust toolchain (1.88 or newer) first" >&2
  exit 1
fi

PY=.venv/bin/python3
if ! "$PY" -c "import pxr.Usd" 2>/dev/null; then
  echo "setup: creating .venv with usd-core ${USD_CORE_VERSION}"
  [ -x "$PY" ] || python3 -m venv .venv
  "$PY" -m pip install --quiet --disable-pip-version-check "usd-core==${USD_CORE_VERSION}"
  "$PY" -c "import pxr.Usd; print('setup: usd-core', pxr.Usd.GetVersion())"
fi

if ! "$PY" -c "import MaterialX" 2>/dev/null; then
  echo "setup: installing MaterialX ${MATERIALX_VERSION} into .venv"
  "$PY" -m pip install --quiet --disable-pip-version-check "MaterialX==${MATERIALX_VERSION}"
  "$PY" -c "import MaterialX; print('setup: MaterialX', MaterialX.getVersionString())"
fi

if ! "$PY" -c "import numpy" 2>/dev/null; then
  echo "setup: installing numpy ${NUMPY_VERSION} into .venv"
  "$PY" -m pip install --quiet --disable-pip-version-check "numpy==${NUMPY_VERSION}"
fi

# Optional: Open Image Denoise (src/denoise). Only the libraries are used, so the wheel's Python
# dependencies are not installed (--no-deps; numpy is there anyway, for the converter). Failing to
# get it (no network, no wheel for this platform) is not an error: the build then has no denoiser
# and says so.
OIDN_LIB=$(ls -d .venv/lib/python3*/site-packages/pyoidn/oidn/lib 2>/dev/null | head -n 1 || true)
if [ "$PYOIDN_VERSION" != none ] && ! [ -f "$OIDN_LIB/libOpenImageDenoise.so" ]; then
  echo "setup: installing Open Image Denoise (pyoidn ${PYOIDN_VERSION}) into .venv"
  if ! "$PY" -m pip install --quiet --disable-pip-version-check --retries 1 --timeout 30 --no-deps "pyoidn==${PYOIDN_VERSION}"; then
    echo "setup: warning: could not install pyoidn: raysplat builds without the denoiser (--denoise is unavailable)" >&2
  fi
fi

# Optional: Embree 4 (the `embree4` feature). Only the shared libraries in `embreex.libs/` are used,
# so the wheel's Python dependencies are not installed. Failing to get it is not an error: the
# default build links Debian's Embree 3, and a build with `--features embree4` then says what is
# missing.
EMBREE4_LIB=$(ls .venv/lib/python3*/site-packages/embreex.libs/libembree4*.so* 2>/dev/null | head -n 1 || true)
if [ "$EMBREEX_VERSION" != none ] && [ -z "$EMBREE4_LIB" ]; then
  echo "setup: installing Embree 4 (embreex ${EMBREEX_VERSION}) into .venv"
  if ! "$PY" -m pip install --quiet --disable-pip-version-check --retries 1 --timeout 30 --no-deps "embreex==${EMBREEX_VERSION}"; then
    echo "setup: warning: could not install embreex: building with --features embree4 is unavailable (the default Embree 3 build is unaffected)" >&2
  fi
fi
