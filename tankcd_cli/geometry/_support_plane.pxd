# The support-plane walk as a C function, for other compiled kernels (see _support_plane.pyx).

cdef int support_plane_c(const double* u, const double* v, const double* z, Py_ssize_t count, double eps,
                         double* out) noexcept nogil
cdef int support_plane_from_c(const double* u, const double* v, const double* z, Py_ssize_t count, double eps,
                              double b0, double c0, double* out) noexcept nogil
