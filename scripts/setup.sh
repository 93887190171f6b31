#!/usr/bin/env bash
# Set up everything the project needs on a fresh Debian machine with Python 3.11: the system packages it
# uses, a virtual environment in .venv, and the package with its development tools. Safe to run again: it
# only does what is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

PYTHON=${PYTHON:-python3}
# Debian packages the toolchain relies on (python3-venv only where the interpreter lacks venv/ensurepip, python3-dev
# only where it lacks its C headers):
# a C compiler with sanitizers, Frama-C with WP, Why3 and z3 (the prover WP calls), cppcheck (with its MISRA
# addon), the Cortex-M cross compiler with its C library, valgrind for the benchmarks, Graphviz for SVG
# diagrams, Chromium for the evidence page's browser test, the X11 and GL libraries libsumo and SUMO load, clang 19
# with LLVM's coverage tools and profile runtime (source-based coverage with MC/DC of the generated C), and QEMU's
# Arm system emulator (the generated tests on a Cortex-M4).
SYSTEM_PACKAGES=(gcc libc6-dev frama-c-base why3 z3 cppcheck gcc-arm-none-eabi libnewlib-arm-none-eabi valgrind
                 graphviz chromium libx11-6 libxext6 libxrender1 libgl1
                 clang-19 llvm-19 libclang-rt-19-dev qemu-system-arm)

apt_install() {
    local sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    echo "setup: installing system packages: $*"
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "$@" >/dev/null
}

if ! command -v "$PYTHON" >/dev/null 2>&1; then
    echo "setup: error: $PYTHON not found; install Python 3.11 or newer" >&2
    exit 2
fi
if ! "$PYTHON" -c 'import sys; sys.exit(sys.version_info < (3, 11))'; then
    echo "setup: error: Python 3.11 or newer is needed, $PYTHON is $("$PYTHON" --version 2>&1)" >&2
    exit 2
fi

missing=()
for pkg in "${SYSTEM_PACKAGES[@]+"${SYSTEM_PACKAGES[@]}"}"; do
    dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
if ! "$PYTHON" -c 'import venv, ensurepip' >/dev/null 2>&1; then
    missing+=("python3-venv")
fi
# The closed loop imports the generated C as a Python extension module, built against the interpreter's Python.h.
if ! "$PYTHON" -c 'import pathlib, sys, sysconfig
sys.exit(not (pathlib.Path(sysconfig.get_paths()["include"]) / "Python.h").is_file())' >/dev/null 2>&1; then
    missing+=("python3-dev")
fi
# Node.js runs SCION, the W3C SCXML interpreter the diagram tests use (tools/scxml).
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
    missing+=("nodejs" "npm")
fi
if [ "${#missing[@]}" -gt 0 ]; then
    apt_install "${missing[@]}"
fi
lock_stamp="tools/scxml/node_modules/.setup-$(sha256sum tools/scxml/package-lock.json | cut -c1-16)"
if [ ! -f "$lock_stamp" ]; then
    echo "setup: installing the SCXML interpreter used by the tests (tools/scxml)"
    (cd tools/scxml && npm ci --no-audit --no-fund --loglevel=error >/dev/null)
    touch "$lock_stamp"
fi

# Frama-C's WP finds provers through Why3's configuration.
if ! grep -q "name = \"Z3\"" "${HOME}/.why3.conf" 2>/dev/null; then
    echo "setup: detecting provers for Why3"
    why3 config detect >/dev/null
fi

if [ ! -x .venv/bin/python ]; then
    echo "setup: creating .venv"
    "$PYTHON" -m venv .venv
fi
stamp=".venv/.setup-$(sha256sum pyproject.toml | cut -c1-16)"
if [ ! -f "$stamp" ]; then
    echo "setup: installing mlca-verify and its development tools into .venv"
    .venv/bin/python -m pip install -q --disable-pip-version-check --upgrade pip
    .venv/bin/python -m pip install -q --disable-pip-version-check -e '.[dev]'
    rm -f .venv/.setup-*
    touch "$stamp"
fi
echo "setup: ready ($(.venv/bin/python --version), $(.venv/bin/python -c 'import z3; print("z3", z3.get_version_string())'))"
