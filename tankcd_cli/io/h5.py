"""Opening tankcd's HDF5 files: one message for each way it can fail."""

from __future__ import annotations

import contextlib

import h5py
import numpy as np

from tankcd_cli.errors import InputError


def open_h5(path: str, fmt: str, version: int, what: str, remedy: str, **options):
    """An open h5py.File of format ``fmt`` and ``version``, or InputError (exit 3); ``options``
    go to h5py.File (e.g. its chunk cache)."""
    try:
        h5 = h5py.File(path, "r", **options)
    except FileNotFoundError:
        raise InputError(path, "no such file") from None
    except (OSError, ValueError, RuntimeError) as exc:
        raise InputError(path, f"cannot read as HDF5: {str(exc).splitlines()[0][:200]}") from None
    try:
        kind = h5.attrs.get("format")
        found = int(h5.attrs.get("format_version", -1))
    except (OSError, RuntimeError, ValueError, TypeError) as exc:
        h5.close()
        raise InputError(path, f"damaged {what}: {str(exc).splitlines()[0][:160]}") from None
    if kind != fmt:
        h5.close()
        raise InputError(path, f"HDF5 file is not a {what} (no format attribute '{fmt}')")
    if found != version:
        h5.close()
        raise InputError(path, f"{what} format version {found}; this tankcd reads version {version}: {remedy}")
    return h5


@contextlib.contextmanager
def read_errors(path: str, what: str):
    """Turn the ways h5py fails on a damaged or foreign file into one InputError line."""
    try:
        yield
    except InputError:
        raise
    except KeyError as exc:
        raise InputError(path, f"not a complete {what} (missing {exc.args[0] if exc.args else 'data'})") from None
    except (OSError, RuntimeError, ValueError, TypeError, IndexError, AttributeError) as exc:
        first = str(exc).splitlines()[0][:160] if str(exc) else type(exc).__name__
        raise InputError(path, f"damaged {what}: {first}") from None


def check_indices(path: str, what: str, index, size: int, name: str) -> None:
    """Every entry of ``index`` lies in [0, size) (-1 allowed where it marks a leaf), or InputError."""
    index = np.asarray(index)
    if index.size and (index.min() < -1 or index.max() >= size):
        raise InputError(path, f"damaged {what}: {name} indices outside 0..{size - 1}")


def is_hdf5(path: str) -> bool:
    """True when ``path`` is an HDF5 file (by its signature): a store, or a tree (``bvh``)."""
    try:
        with open(path, "rb") as fh:
            return fh.read(8) == b"\x89HDF\r\n\x1a\n"
    except OSError:
        return False
