#!/usr/bin/env bash
# Creates bench/peer/.venv with pinned packages for the numpy peer of the likelihood bench
# (benches/likelihood.rs runs bench/peer/numpy_lnl.py with this venv's python when it exists)
# and for the nested-sampling peers (bench/peer/nested_peers.py, nested_vs_occam.py): dynesty
# and nautilus-sampler, with the numerical packages they pull in pinned as measured.
#   bash bench/peer/setup.sh
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
python="${PYTHON:-python3}"
# numpy 2.4 needs Python >= 3.11
"$python" -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else "numpy 2.4 needs Python >= 3.11; set PYTHON=/path/to/python3.11+")'
if [ ! -x "$here/.venv/bin/python" ]; then
    "$python" -m venv "$here/.venv"
fi
"$here/.venv/bin/python" -m pip install --quiet --disable-pip-version-check \
    "numpy==2.4.6" \
    "dynesty==3.1.0" \
    "nautilus-sampler==1.0.6" \
    "scipy==1.17.1" \
    "scikit-learn==1.9.1" \
    "threadpoolctl==3.8.0"
"$here/.venv/bin/python" -c '
import numpy, scipy, sklearn, dynesty, nautilus
print("numpy", numpy.__version__, "in", numpy.__file__)
print("scipy", scipy.__version__, "scikit-learn", sklearn.__version__,
      "dynesty", dynesty.__version__, "nautilus-sampler", nautilus.__version__)'
