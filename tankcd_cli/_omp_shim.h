/* OpenMP where the compiler has it, one thread where it does not (see setup.py). */
#ifdef _OPENMP
#include <omp.h>
static int tcd_openmp(void) { return 1; }
static int tcd_max_threads(void) { return omp_get_max_threads(); }
static void tcd_set_threads(int n) { omp_set_num_threads(n); }
#else
static int tcd_openmp(void) { return 0; }
static int tcd_max_threads(void) { return 1; }
static void tcd_set_threads(int n) { (void)n; }
#endif
