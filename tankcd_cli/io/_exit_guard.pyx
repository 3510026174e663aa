# SIGTERM answered within a grace period even where the run cannot (the wrapper: io/exit_guard.py).
#
# Python runs a signal's handler only when the main thread next executes Python code; a compiled
# kernel or a library call (a convolution, a warp, a thread pool's shutdown) can keep it away for
# a minute. The handler installed here runs in C when the signal arrives: it passes the signal on
# to Python's own handler (the run ends as usual when it can) and sets an alarm; when the alarm
# rings the run has not ended, and the alarm's handler removes the temporary outputs still
# registered here and ends the process with 143 (as a SIGTERM'd run exits). Both handlers use only
# async-signal-safe calls (unlink, write, alarm, _exit).

from libc.string cimport strlen, strncpy, strcmp

cdef extern from "<signal.h>" nogil:
    ctypedef void (*sighandler_t)(int)
    ctypedef struct sigset_t:
        pass
    cdef struct sigaction:
        sighandler_t sa_handler
        sigset_t sa_mask
        int sa_flags
    int c_sigaction "sigaction"(int signum, const sigaction* act, sigaction* oldact)
    int sigemptyset(sigset_t* s)
    int SIGTERM
    int SIGALRM
    int SA_SIGINFO
    int SA_RESTART
    sighandler_t SIG_DFL
    sighandler_t SIG_IGN

cdef extern from "<unistd.h>" nogil:
    unsigned int alarm(unsigned int seconds)
    int unlink(const char* path)
    ssize_t write(int fd, const void* buf, size_t count)
    void _exit(int status)

cdef extern from *:
    """
    static void tankcd_barrier(void) { __sync_synchronize(); }
    """
    void tankcd_barrier() nogil

DEF SLOTS = 128
DEF PATH_BYTES = 4096

cdef char _paths[SLOTS][PATH_BYTES]
cdef volatile int _used[SLOTS]
cdef sighandler_t _python_handler = NULL
cdef volatile int _armed = 0
cdef unsigned int _grace = 1
cdef bint _installed = False
cdef const char* _MESSAGE = b"tankcd: terminated\n"


cdef void _on_term(int signum) noexcept nogil:
    global _armed
    if _python_handler != NULL and _python_handler != SIG_DFL and _python_handler != SIG_IGN:
        _python_handler(signum)
    if not _armed:
        _armed = 1
        alarm(_grace)


cdef void _on_alarm(int signum) noexcept nogil:
    cdef int k
    for k in range(SLOTS):
        if _used[k]:
            unlink(_paths[k])
    write(2, _MESSAGE, strlen(_MESSAGE))
    _exit(143)


def install(unsigned int grace_seconds=1):
    """Put the C handler in front of the SIGTERM handler Python has (install that first); True
    when installed (False where the handler Python has cannot be chained)."""
    global _python_handler, _grace, _installed
    cdef sigaction act, old
    if _installed:
        return True
    if c_sigaction(SIGTERM, NULL, &old) != 0 or (old.sa_flags & SA_SIGINFO):
        return False
    _python_handler = old.sa_handler
    _grace = grace_seconds if grace_seconds > 0 else 1
    act.sa_handler = _on_alarm
    sigemptyset(&act.sa_mask)
    act.sa_flags = 0
    if c_sigaction(SIGALRM, &act, NULL) != 0:
        return False
    act.sa_handler = _on_term
    act.sa_flags = old.sa_flags
    if c_sigaction(SIGTERM, &act, NULL) != 0:
        return False
    _installed = True
    return True


def track(bytes path):
    """Register a temporary output for removal by the forced exit; False when no slot is free (the
    run's own clean-up and the next run's clearing of dead parts still apply) or the path is too long."""
    cdef int k
    if len(path) >= PATH_BYTES:
        return False
    for k in range(SLOTS):
        if not _used[k]:
            strncpy(_paths[k], path, PATH_BYTES - 1)
            _paths[k][PATH_BYTES - 1] = 0
            tankcd_barrier()  # the path is whole before the slot counts
            _used[k] = 1
            return True
    return False


def untrack(bytes path):
    """Forget a temporary output (renamed onto its target, or removed)."""
    cdef int k
    for k in range(SLOTS):
        if _used[k] and strcmp(_paths[k], path) == 0:
            _used[k] = 0
            tankcd_barrier()


def tracked():
    """The registered paths (for tests)."""
    cdef int k
    return [bytes(_paths[k]) for k in range(SLOTS) if _used[k]]
