"""One OpenBLAS thread for the commands' processes.

numpy's and SciPy's wheels each carry an OpenBLAS that starts a thread per core when it loads,
and such a thread spins, waiting for work, about 0.1 s of CPU when it starts and again after
every call it shares (a dot product of more than 10,000 numbers, say). The commands spread
their work over the cores themselves — the camera's worker process and the mosaic's threads in
``mcl run``, the search's threads in ``mclc`` — so those threads only take CPU from them:
measured on this 2-core machine, importing numpy and SciPy's sparse solver 0.51 s of CPU
against 0.27 s with one thread, and a dam run's mosaic spun 0.9 s more in its alignment's
residuals (perf: ``blas_thread_server``). No figure changes: the same products, on one thread.
"""

from __future__ import annotations

import os
import sys

VARIABLE = "OPENBLAS_NUM_THREADS"  # read by both OpenBLAS libraries when they load


def one_blas_thread() -> None:
    """Ask OpenBLAS for one thread in this process and the processes it starts, unless the
    user chose a number (the variable set) or numpy is loaded already (too late to ask)."""
    if "numpy" not in sys.modules:
        os.environ.setdefault(VARIABLE, "1")
