"""One BLAS thread per fxdsp process unless the environment names another count.

Set by the command line (and the test suite's conftest) before anything imports numpy; every child
(the sweep's local workers, a CLI run by a test) inherits it. Two reasons, both measured:

* A report's bytes must not depend on the machine's core count. OpenBLAS splits a product over its
  threads and the split changes the rounding: the tckit log's diagnosis gave a lag of tau
  935.7556546006896 s on this 2-core machine's two threads and 935.7556546003867 s on one, and the
  tests, which run one thread, check the second.
* The diagnosis solves many small least squares; a second thread only waits, spinning, for a core
  another process holds (two pytest workers, two sweep workers): np.linalg.lstsq 3000 x 12 ran
  2.2 s per 3000 calls on two threads against 0.77 s on one.

An explicit OPENBLAS_NUM_THREADS in the environment wins (a user who wants the threads keeps them).
"""

from __future__ import annotations

import os

VARIABLE = "OPENBLAS_NUM_THREADS"


def one_blas_thread() -> None:
    """OPENBLAS_NUM_THREADS=1 in this process's environment unless it is set; only effective before
    numpy is first imported (OpenBLAS reads it once, when it loads)."""
    os.environ.setdefault(VARIABLE, "1")
