#!/usr/bin/env bash
# Regenerate the locks in requirements/: resolve each install profile with pip in a fresh virtual
# environment and freeze it. Run from anywhere: `bash requirements/regenerate.sh`.
#
#   core.txt  pip install -e .                      (the main job, no extras)
#   dev.txt   pip install -e ".[dev,train,ray]"     (linters, tests, training, Ray)
#
# torch is left out of every lock on purpose: it is the CPU build that the Quick start installs
# first (`pip install torch==2.13.0`); a lock that pinned it would make pip pull the CUDA build
# and its nvidia-* wheels (gigabytes). The script fails if an nvidia-* or torch line slips in.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
python="${PYTHON:-python3}"

lock() {  # lock NAME EXTRAS
    local name="$1" extras="$2" venv="$work/$1" out="$root/requirements/$1.txt"
    "$python" -m venv "$venv"
    if [ -n "$extras" ]; then
        "$venv/bin/pip" install -q torch==2.13.0
    fi
    "$venv/bin/pip" install -q "$root$extras"
    {
        echo "# Lock of the '$name' install profile (pip install -e \".$extras\"): the exact versions"
        echo "# CI tested. Regenerate: bash requirements/regenerate.sh"
        echo "# Resolved with $("$venv/bin/python" -V) on $(uname -s) $(uname -m)."
        echo "# torch is not pinned here: install the CPU build first (pip install torch==2.13.0)."
        "$venv/bin/pip" freeze --all --exclude-editable \
            | grep -v -i -E '^(superlane-tools|superlane_tools|torch|pip)( @|==)' | LC_ALL=C sort -f
    } >"$out.tmp"
    if grep -q -i -E '^(nvidia-|torch==)' "$out.tmp"; then
        echo "regenerate: $name lock would pull CUDA/torch wheels:" >&2
        grep -i -E '^(nvidia-|torch==)' "$out.tmp" >&2
        rm -f "$out.tmp"
        exit 1
    fi
    mv "$out.tmp" "$out"
    echo "wrote $out ($(grep -c '==' "$out") pins)"
}

lock core ""
lock dev "[dev,train,ray]"
