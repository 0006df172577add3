#!/usr/bin/env bash
# Creates bench/peer/.venv with a pinned numpy for the numpy peer of the likelihood bench
# (benches/likelihood.rs runs bench/peer/numpy_lnl.py with this venv's python when it exists).
#   bash bench/peer/setup.sh
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
python="${PYTHON:-python3}"
# numpy 2.4 needs Python >= 3.11
"$python" -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else "numpy 2.4 needs Python >= 3.11; set PYTHON=/path/to/python3.11+")'
if [ ! -x "$here/.venv/bin/python" ]; then
    "$python" -m venv "$here/.venv"
fi
"$here/.venv/bin/python" -m pip install --quiet --disable-pip-version-check "numpy==2.4.6"
"$here/.venv/bin/python" -c 'import numpy; print("numpy", numpy.__version__, "in", numpy.__file__)'
