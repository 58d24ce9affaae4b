#!/usr/bin/env bash
# Installs mitsuba_pbrdf and what it needs on a fresh Debian machine:
#   ./install.sh          the product: Debian's libllvm19 (Dr.Jit's llvm_* variants
#                         crash inside mi.render with Debian's default LLVM 15; Dr.Jit
#                         picks the newest libLLVM it finds) and a virtual environment
#                         .venv with the package. Compiles nothing.
#   ./install.sh --test   the same plus the test extra: a C++ compiler and the Python
#                         headers, since the test extra's pyscatmech (NIST SCATMECH, an
#                         independent oracle) builds from source (a few minutes of g++
#                         the first time).
# Safe to run again: it skips what is already there.
set -euo pipefail
cd "$(dirname "$0")"

EXTRA=""
for arg in "$@"; do
    case "$arg" in
        --test) EXTRA="[test]" ;;
        -h|--help) sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "install.sh: error: unknown option $arg (use --test, or nothing)" >&2; exit 2 ;;
    esac
done

SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
apt_install() {
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "$@" >/dev/null
}

have_llvm19() {   # (ls of both globs fails when either is missing: test each)
    compgen -G "/usr/lib/*-linux-gnu/libLLVM-19.so*" >/dev/null ||
        compgen -G "/usr/lib/llvm-19/lib/libLLVM*.so*" >/dev/null
}
if ! have_llvm19; then
    echo "install.sh: installing Debian's libllvm19" >&2
    apt_install libllvm19
fi

PYTHON="${PYTHON:-python3}"
if [ -n "$EXTRA" ]; then
    PY_INCLUDE="$("$PYTHON" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')"
    if ! command -v g++ >/dev/null 2>&1 || [ ! -f "$PY_INCLUDE/Python.h" ]; then
        echo "install.sh: installing g++ and the Python headers (to build pyscatmech)" >&2
        apt_install g++ python3-dev
    fi
fi

[ -x .venv/bin/python ] || "$PYTHON" -m venv .venv
.venv/bin/python -m pip install -q --upgrade pip >/dev/null
.venv/bin/python -m pip install -q -e ".$EXTRA"
echo "install.sh: ready (.venv/bin/python${EXTRA:+, with the test extra})" >&2
