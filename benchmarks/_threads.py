"""Thread pinning shared by the benchmark scripts (importable from them: the scripts' folder is on ``sys.path``).

It imports nothing from sindybench, so a script can call it before its first import of the package.
"""

import os


def pin_threads(argv):
    """Numba reads its thread count at import: set it (and BLAS's) before sindybench is imported.

    ``--threads N`` in ``argv`` sets ``N`` (default 1); variables already set are kept.
    """
    threads = "1"
    if "--threads" in argv:
        threads = argv[argv.index("--threads") + 1]
    for name in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(name, threads)
