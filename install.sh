#!/usr/bin/env bash
# Installs mitsuba_pbrdf and what it needs on a fresh Debian machine:
#   - Debian's libllvm19 (Dr.Jit's llvm_* variants crash inside mi.render with
#     Debian's default LLVM 15; Dr.Jit picks the newest libLLVM it finds),
#   - a C++ compiler and the Python headers (the test extra's pyscatmech builds
#     NIST's SCATMECH from source; a few minutes of g++ the first time),
#   - a virtual environment .venv with the package and its test extra.
# Safe to run again: it skips what is already there.
set -euo pipefail
cd "$(dirname "$0")"

if ! ls /usr/lib/*-linux-gnu/libLLVM-19.so* /usr/lib/llvm-19/lib/libLLVM*.so* >/dev/null 2>&1; then
    echo "install.sh: installing Debian's libllvm19" >&2
    SUDO=""
    [ "$(id -u)" -eq 0 ] || SUDO="sudo"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends libllvm19 >/dev/null
fi

PYTHON="${PYTHON:-python3}"
PY_INCLUDE="$("$PYTHON" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')"
if ! command -v g++ >/dev/null 2>&1 || [ ! -f "$PY_INCLUDE/Python.h" ]; then
    echo "install.sh: installing g++ and the Python headers (to build pyscatmech)" >&2
    SUDO=""
    [ "$(id -u)" -eq 0 ] || SUDO="sudo"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
        g++ python3-dev >/dev/null
fi

[ -x .venv/bin/python ] || "$PYTHON" -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip >/dev/null
.venv/bin/python -m pip install -q -e ".[test]"
echo "install.sh: ready (.venv/bin/python)" >&2
