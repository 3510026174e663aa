# GJK between two finite cylinders, for other compiled kernels to cimport (see _cylinders.pyx).

cdef double gjk_c(const double* cA, const double* aA, double hA, double rA,
                  const double* cB, const double* aB, double hB, double rB,
                  double nx, double ny, double nz, double tol, bint stop_apart, int* err) noexcept nogil
