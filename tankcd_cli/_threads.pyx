"""Threads of the compiled kernels (OpenMP): how many, and whether there is OpenMP at all."""

cdef extern from "_omp_shim.h":
    int tcd_openmp() nogil
    int tcd_max_threads() nogil
    void tcd_set_threads(int n) nogil


def openmp_enabled() -> bool:
    """True when the kernels were built with OpenMP (their parallel loops use several threads)."""
    return tcd_openmp() == 1


def get_num_threads() -> int:
    return tcd_max_threads()


def set_num_threads(int n) -> None:
    """Threads for the kernels' parallel loops from now on in this process (at least 1)."""
    tcd_set_threads(max(1, n))
