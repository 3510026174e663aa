"""The gun's compiled kernels: the walk along its angle path (see ``collision.internal.first_gun_contacts``).

Per path, in OpenMP threads: the barrel placed at (azimuth, elevation) as ``internal.barrel``
places it, GJK's distance to each drum, an advance by the clearance over the barrel's speed (never
less than the fixed step, and only the fixed step when closer than ``close``), until a drum is
touched or the path ends.
"""

from cython.parallel cimport prange
from libc.math cimport cos, sin, INFINITY
from libc.stdint cimport int64_t

import numpy as np

from tankcd_cli.geometry._cylinders cimport gjk_c


def gun_path_contacts(az0, daz, el0, dele, barrel_params, drum_centres, drum_params, double speed_az,
                      double speed_el, double step_rad, double close, double tol):
    """found (M,) int64, s (M,) (NaN where none), drum (M,) int64 (-1 where none), errors (count).

    barrel_params : (turret_x, trunnion_forward, trunnion_height, half_length, radius)
    drum_centres : (D, 3); drum_params : (D, 2) half-length and radius; every drum's axis is +y
    speed_az, speed_el : the farthest a barrel point is from the turret axis and from the trunnion, m
    """
    cdef const double[::1] a0 = np.ascontiguousarray(az0, dtype=np.float64).ravel()
    cdef const double[::1] da = np.ascontiguousarray(daz, dtype=np.float64).ravel()
    cdef const double[::1] e0 = np.ascontiguousarray(el0, dtype=np.float64).ravel()
    cdef const double[::1] de = np.ascontiguousarray(dele, dtype=np.float64).ravel()
    cdef const double[::1] bp = np.ascontiguousarray(barrel_params, dtype=np.float64).ravel()
    cdef const double[:, ::1] dc = np.ascontiguousarray(drum_centres, dtype=np.float64).reshape(-1, 3)
    cdef const double[:, ::1] dp = np.ascontiguousarray(drum_params, dtype=np.float64).reshape(-1, 2)
    cdef Py_ssize_t m = a0.shape[0]
    cdef Py_ssize_t nd = dc.shape[0]
    found_arr = np.zeros(m, np.int64)
    s_arr = np.full(m, np.nan)
    drum_arr = np.full(m, -1, np.int64)
    cdef int64_t[::1] found = found_arr
    cdef double[::1] s_out = s_arr
    cdef int64_t[::1] drum = drum_arr
    cdef Py_ssize_t i
    cdef int bad = 0
    if m == 0 or nd == 0:
        return found_arr, s_arr, drum_arr, 0
    with nogil:
        for i in prange(m, schedule="dynamic", chunksize=16):
            bad += _walk(a0[i], da[i], e0[i], de[i], &bp[0], &dc[0, 0], &dp[0, 0], nd, speed_az, speed_el,
                         step_rad, close, tol, &found[i], &s_out[i], &drum[i])
    return found_arr, s_arr, drum_arr, bad


cdef int _walk(double a0, double da, double e0, double de, const double* bp, const double* dc, const double* dp,
               Py_ssize_t nd, double speed_az, double speed_el, double step_rad, double close, double tol,
               int64_t* found, double* s_out, int64_t* drum) noexcept nogil:
    cdef double speed = (da if da >= 0 else -da) * speed_az + (de if de >= 0 else -de) * speed_el
    cdef double turn = da if da >= 0 else -da
    cdef double turn_el = de if de >= 0 else -de
    if turn_el > turn:
        turn = turn_el
    cdef double fixed = step_rad / turn if turn > 0 else INFINITY
    cdef double s = 0.0
    cdef double az, el, ca, sa, ce, se, d, clear, ahead
    cdef double centre[3]
    cdef double axis[3]
    cdef double up[3]
    cdef int err = 0
    cdef Py_ssize_t j
    up[0] = 0.0
    up[1] = 1.0
    up[2] = 0.0
    while True:
        az = a0 + s * da
        el = e0 + s * de
        ca = cos(az)
        sa = sin(az)
        ce = cos(el)
        se = sin(el)
        axis[0] = ce * ca
        axis[1] = ce * sa
        axis[2] = se
        centre[0] = bp[0] + bp[1] * ca + bp[3] * axis[0]
        centre[1] = bp[1] * sa + bp[3] * axis[1]
        centre[2] = bp[2] + bp[3] * axis[2]
        clear = INFINITY
        for j in range(nd):
            d = gjk_c(centre, axis, bp[3], bp[4], dc + 3 * j, up, dp[2 * j], dp[2 * j + 1], 0.0, 0.0, 0.0, tol,
                      False, &err)
            if err:
                return 1
            if d <= tol:
                found[0] = 1
                s_out[0] = s
                drum[0] = j
                return 0
            if d - tol < clear:
                clear = d - tol
        if speed <= 0:
            return 0
        ahead = clear / speed
        if clear <= close or ahead < fixed:
            ahead = fixed
        s = s + ahead
        if s > 1.0:
            return 0
