"""Opening tankcd's HDF5 files: one message for each way it can fail."""

from __future__ import annotations

from tankcd_cli.errors import InputError


def open_h5(path: str, fmt: str, version: int, what: str, remedy: str):
    """An open h5py.File of format ``fmt`` and ``version``, or InputError (exit 3)."""
    import h5py

    try:
        h5 = h5py.File(path, "r")
    except FileNotFoundError:
        raise InputError(path, "no such file") from None
    except (OSError, ValueError) as exc:
        raise InputError(path, f"cannot read as HDF5: {str(exc).splitlines()[0][:200]}") from None
    if h5.attrs.get("format") != fmt:
        h5.close()
        raise InputError(path, f"HDF5 file is not a {what} (no format attribute '{fmt}')")
    found = int(h5.attrs.get("format_version", -1))
    if found != version:
        h5.close()
        raise InputError(path, f"{what} format version {found}; this tankcd reads version {version}: {remedy}")
    return h5
