# A median-split k-d tree over 3-D points and its K-nearest search, compiled inline into the kernels
# that cimport it (terrain/curvature/_jet_fit.pyx). Squared distances are summed x, y, then z, as
# scipy's cKDTree sums them, so the neighbours chosen from them are cKDTree's to the bit.

from libc.stdint cimport int64_t
from libc.stdlib cimport free, malloc

cdef enum:
    LEAF = 16         # points per kd-tree leaf at most (at least LEAF // 2 once split)
    STACK = 192       # traversal stack: depth + 1 entries suffice (depth < 64 for any int64 count)


cdef struct Tree:
    double* X          # (m, 3) points in tree order
    int64_t* ID        # (m,) their index in the input
    double* box        # (nodes, 6) tight bounding box: lo x y z, hi x y z
    int64_t* start     # (nodes,) first point
    int64_t* end       # (nodes,) one past the last point
    int64_t* left      # (nodes,) left child, -1 for a leaf (the right child is left + 1)
    int64_t nodes
    int64_t m


cdef inline void swap_points(double* X, int64_t* ID, int64_t i, int64_t j) noexcept nogil:
    cdef double t
    cdef int64_t ti
    cdef int c
    for c in range(3):
        t = X[3 * i + c]
        X[3 * i + c] = X[3 * j + c]
        X[3 * j + c] = t
    ti = ID[i]
    ID[i] = ID[j]
    ID[j] = ti


cdef inline void select_on_axis(double* X, int64_t* ID, int64_t lo, int64_t hi, int64_t kth, int d) noexcept nogil:
    """Quickselect on coordinate d of points lo..hi (inclusive): point kth ends in its sorted place,
    smaller-or-equal ones before, larger-or-equal after."""
    cdef int64_t i, j, mid
    cdef double a, b, c, pivot
    while hi > lo:
        mid = lo + (hi - lo) // 2
        a = X[3 * lo + d]
        b = X[3 * mid + d]
        c = X[3 * hi + d]
        if a < b:
            if b < c:
                pivot = b
            elif a < c:
                pivot = c
            else:
                pivot = a
        else:
            if a < c:
                pivot = a
            elif b < c:
                pivot = c
            else:
                pivot = b
        i = lo
        j = hi
        while i <= j:
            while X[3 * i + d] < pivot:
                i += 1
            while X[3 * j + d] > pivot:
                j -= 1
            if i <= j:
                swap_points(X, ID, i, j)
                i += 1
                j -= 1
        if kth <= j:
            hi = j
        elif kth >= i:
            lo = i
        else:
            return


cdef inline double x_at(Tree* t, int64_t p, int c) noexcept nogil:
    return t.X[3 * p + c]


cdef inline void build_node(Tree* t, int64_t node, int64_t s, int64_t e, int64_t* next_node) noexcept nogil:
    """Node ``node`` over points s..e-1: its box, and its children when it has more than LEAF points."""
    cdef double* bx = t.box + 6 * node
    cdef int64_t p, mid, child
    cdef int c, d
    cdef double v, w, widest
    for c in range(3):
        bx[c] = x_at(t, s, c)
        bx[3 + c] = bx[c]
    for p in range(s + 1, e):
        for c in range(3):
            v = t.X[3 * p + c]
            if v < bx[c]:
                bx[c] = v
            if v > bx[3 + c]:
                bx[3 + c] = v
    t.start[node] = s
    t.end[node] = e
    if e - s <= LEAF:
        t.left[node] = -1
        return
    d = 0
    widest = bx[3] - bx[0]
    for c in range(1, 3):
        w = bx[3 + c] - bx[c]
        if w > widest:
            widest = w
            d = c
    mid = s + (e - s) // 2
    select_on_axis(t.X, t.ID, s, e - 1, mid, d)
    child = next_node[0]
    next_node[0] += 2
    t.left[node] = child
    build_node(t, child, s, mid, next_node)
    build_node(t, child + 1, mid, e, next_node)


cdef inline int tree_alloc(Tree* t, int64_t m) noexcept nogil:
    cdef int64_t cap = 2 * (m // ((LEAF + 1) // 2)) + 3
    t.m = m
    t.nodes = cap
    t.X = <double*>malloc((3 * m + 1) * sizeof(double))
    t.ID = <int64_t*>malloc((m + 1) * sizeof(int64_t))
    t.box = <double*>malloc(6 * cap * sizeof(double))
    t.start = <int64_t*>malloc(cap * sizeof(int64_t))
    t.end = <int64_t*>malloc(cap * sizeof(int64_t))
    t.left = <int64_t*>malloc(cap * sizeof(int64_t))
    if t.X == NULL or t.ID == NULL or t.box == NULL or t.start == NULL or t.end == NULL or t.left == NULL:
        return -1
    return 0


cdef inline void tree_free(Tree* t) noexcept nogil:
    free(t.X)
    free(t.ID)
    free(t.box)
    free(t.start)
    free(t.end)
    free(t.left)


cdef inline double box_dist2(const double* bx, const double* q) noexcept nogil:
    cdef double s = 0.0, g
    cdef int c
    for c in range(3):
        g = bx[c] - q[c]
        if g > 0.0:
            s += g * g
        else:
            g = q[c] - bx[3 + c]
            if g > 0.0:
                s += g * g
    return s


cdef inline bint comes_before(double da, int64_t ia, double db, int64_t ib) noexcept nogil:
    return da < db or (da == db and ia < ib)


cdef inline void select_pairs(double* bd, int64_t* bi, int64_t n, int64_t kth) noexcept nogil:
    """Quickselect on (bd, bi) pairs, ordered by (distance, index): entry kth ends in its sorted
    place, smaller ones before it. The pairs are distinct (each point is seen once)."""
    cdef int64_t lo = 0, hi = n - 1, i, j, mid, ti
    cdef double pd, td
    cdef int64_t pi
    while hi > lo:
        mid = lo + (hi - lo) // 2
        # median of three as the pivot
        if bd[mid] < bd[lo] or (bd[mid] == bd[lo] and bi[mid] < bi[lo]):
            td = bd[mid]; bd[mid] = bd[lo]; bd[lo] = td
            ti = bi[mid]; bi[mid] = bi[lo]; bi[lo] = ti
        if bd[hi] < bd[lo] or (bd[hi] == bd[lo] and bi[hi] < bi[lo]):
            td = bd[hi]; bd[hi] = bd[lo]; bd[lo] = td
            ti = bi[hi]; bi[hi] = bi[lo]; bi[lo] = ti
        if bd[hi] < bd[mid] or (bd[hi] == bd[mid] and bi[hi] < bi[mid]):
            td = bd[hi]; bd[hi] = bd[mid]; bd[mid] = td
            ti = bi[hi]; bi[hi] = bi[mid]; bi[mid] = ti
        pd = bd[mid]
        pi = bi[mid]
        i = lo
        j = hi
        while i <= j:
            while bd[i] < pd or (bd[i] == pd and bi[i] < pi):
                i += 1
            while bd[j] > pd or (bd[j] == pd and bi[j] > pi):
                j -= 1
            if i <= j:
                td = bd[i]; bd[i] = bd[j]; bd[j] = td
                ti = bi[i]; bi[i] = bi[j]; bi[j] = ti
                i += 1
                j -= 1
        if kth <= j:
            hi = j
        elif kth >= i:
            lo = i
        else:
            return


cdef inline int64_t keep_nearest(double* bd, int64_t* bi, int64_t n, int64_t K, double* cd, int64_t* ci) noexcept nogil:
    """Keep the K nearest of the n candidates, in their order (the visiting order: the result then
    does not depend on when this ran). cd, ci: scratch (n), cd[K - 1] the K-th distance after."""
    cdef int64_t j, c = 0
    for j in range(n):
        cd[j] = bd[j]
        ci[j] = bi[j]
    select_pairs(cd, ci, n, K - 1)
    for j in range(n):
        if not comes_before(cd[K - 1], ci[K - 1], bd[j], bi[j]):
            bd[c] = bd[j]
            bi[c] = bi[j]
            c += 1
    return c


cdef inline int64_t knn_candidates(const Tree* t, const double* q, int64_t K, double r2, double* bd, int64_t* bi,
                  int64_t cap, int64_t* st_node, double* st_dist, double* r2_out, double* cd,
                  int64_t* ci) noexcept nogil:
    """Candidates for the K nearest points of q, in no order: bd, bi (squared distances, indices;
    the buffers hold cap >= 2 K), every point nearer than the K-th among them. r2: a squared
    radius known to hold K points (inf: none known). Points within r2 are gathered; a full buffer
    keeps its K nearest and shrinks r2 (r2_out: the radius at the end; cd, ci: scratch of cap).
    The candidates come in the tree's visiting order, whatever r2 was. Returns how many."""
    cdef int64_t sp, cnt = 0, node, l, p, i
    cdef double dmin, dl, dr, dx, dy, dz, d2
    cdef const double* X = t.X
    st_node[0] = 0
    st_dist[0] = box_dist2(t.box, q)
    sp = 1
    while sp > 0:
        sp -= 1
        node = st_node[sp]
        if st_dist[sp] > r2:
            continue
        l = t.left[node]
        if l < 0:
            for p in range(t.start[node], t.end[node]):
                dx = X[3 * p] - q[0]
                dy = X[3 * p + 1] - q[1]
                dz = X[3 * p + 2] - q[2]
                d2 = dx * dx + dy * dy  # cKDTree's sum: x, y, then z
                d2 = d2 + dz * dz
                bd[cnt] = d2  # branch-free: written always, kept when within r2
                bi[cnt] = t.ID[p]
                cnt += <int64_t>(d2 <= r2)
                if cnt == cap:
                    cnt = keep_nearest(bd, bi, cnt, K, cd, ci)
                    r2 = cd[K - 1]
        else:
            dl = box_dist2(t.box + 6 * l, q)
            dr = box_dist2(t.box + 6 * (l + 1), q)
            if sp + 2 > STACK:  # cannot happen for a median-split tree of < 2^63 points
                sp = STACK - 2
            if dl <= dr:
                st_node[sp] = l + 1
                st_dist[sp] = dr
                st_node[sp + 1] = l
                st_dist[sp + 1] = dl
            else:
                st_node[sp] = l
                st_dist[sp] = dl
                st_node[sp + 1] = l + 1
                st_dist[sp + 1] = dr
            sp += 2
    r2_out[0] = r2
    return cnt
