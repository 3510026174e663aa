"""What both layouts of the terrain store (HDF5) share: the format's name and version, the root
attribute ``layout`` that names the layout (``mesh``: ``mesh/store.py``; ``grid``:
``grid/store.py``), and reading the root attributes without any array.

A file is told to be HDF5 by its signature (``io.h5.is_hdf5``); ``open_store`` opens it as a terrain
store, refusing another format or an older version with a one-line "run classify again".
"""

from __future__ import annotations

import numpy as np

from tankcd_cli.io.h5 import open_h5, read_errors

FORMAT = "tankcd-terrain"
FORMAT_VERSION = 2  # 2: a root attribute ``layout`` (mesh | grid); DEMs in the grid layout (grid/store.py)
WHAT = "tankcd terrain store"  # how messages name a store


def open_store(path: str, **kwargs):
    """The h5py file of a terrain store, checked for the format and its version (InputError
    otherwise); ``kwargs`` go to h5py (e.g. ``rdcc_nbytes``)."""
    return open_h5(path, FORMAT, FORMAT_VERSION, WHAT, "run classify again", **kwargs)


def read_attrs(path: str) -> dict:
    """Root attributes of a store, without reading its arrays."""
    h5 = open_store(path)
    with h5, read_errors(path, WHAT):
        # list() first: a lazily iterated h5py view holds h5py's lock while suspended, and an error in
        # plain_value would leave it suspended (a later garbage collection in another thread deadlocks)
        return {k: plain_value(v) for k, v in list(h5.attrs.items())}


def store_layout(path: str) -> str:
    """'grid' or 'mesh' for a terrain store (its root attribute ``layout``)."""
    return str(read_attrs(path).get("layout", "mesh"))


def plain_value(value):
    """An HDF5 attribute as a plain Python value: text, a number, a list."""
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value
