"""Threads of the compiled kernels' parallel loops (OpenMP), compiled ahead of time (Cython,
``_threads.pyx``).

openmp_enabled() -> whether the kernels were built with OpenMP (else they run on one thread)
get_num_threads() -> the threads their parallel loops use
set_num_threads(n) -> use n (at least 1) from now on in this process
"""

from tankcd_cli._threads import get_num_threads, openmp_enabled, set_num_threads  # noqa: F401
