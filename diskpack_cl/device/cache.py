"""The user's cache folder of the device layer: check verdicts, kept program binaries,
PoCL's own kernel cache.

Its own module, read without pyopencl: the device context points PoCL at it
before PoCL is loaded, and both the checks and the program builder keep
files in it.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["cache_dir"]


def cache_dir():
    """The folder of the verdicts: ``$DISKPACK_CL_CACHE_DIR``, else ``$XDG_CACHE_HOME/diskpack_cl``
    (``~/.cache/diskpack_cl``).

    Examples
    --------
    >>> isinstance(cache_dir(), Path)
    True
    """
    env = os.environ.get("DISKPACK_CL_CACHE_DIR")
    if env:
        return Path(env)
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "diskpack_cl"
