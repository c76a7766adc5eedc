"""Modules that moved into the subpackages, kept importable by their old names for one
release: ``import diskpack_cl.tiles`` gives :mod:`diskpack_cl.jobs.tiles`, with a
:class:`DeprecationWarning` naming the new home.

Examples
--------
>>> import warnings, importlib
>>> with warnings.catch_warnings(record=True) as caught:
...     warnings.simplefilter("always")
...     old = importlib.import_module("diskpack_cl.batch")
>>> old.__name__, "diskpack_cl.jobs.batch" in str(caught[0].message)
('diskpack_cl.jobs.batch', True)
"""

import importlib
import importlib.util
import sys
import warnings

__all__ = ["MOVED", "install"]

#: Old module name -> new one.
MOVED = {f"diskpack_cl.{old}": f"diskpack_cl.{new}" for old, new in {
    "device_checks": "device.checks", "known_answers": "device.known_answers",
    "device_stage": "device.stage", "raster": "device.raster", "cells": "device.cells",
    "cells3": "device.cells3", "blur": "device.blur",
    "export": "drawing.writers", "color_export": "drawing.color_writers",
    "readers": "drawing.readers", "plotters": "drawing.plotters", "overlap": "drawing.overlap",
    "pen_path": "drawing.pen_path",
    "executors": "jobs.executors", "batch": "jobs.batch", "tiles": "jobs.tiles",
}.items()}


class _Alias:
    # the import system's loader protocol, duck-typed: importlib.abc would load
    # importlib.resources (13 ms) at every start of the package

    def create_module(self, spec):
        warnings.warn(f"{spec.name} moved to {MOVED[spec.name]}: import it from there (the old "
                      f"name goes in the next release)", DeprecationWarning, stacklevel=2)
        module = importlib.import_module(MOVED[spec.name])
        self.spec = module.__spec__
        return module

    def exec_module(self, module):
        # the new module ran when it was imported; the import system gave it the old name's
        # spec meanwhile, which its relative imports would read
        module.__spec__ = self.spec


class _Finder:
    # a meta path finder, duck-typed as _Alias

    def find_spec(self, name, path=None, target=None):
        if name in MOVED:
            return importlib.util.spec_from_loader(name, _Alias())
        return None


def install():
    """Put the finder of the old names on :data:`sys.meta_path` (once; the package does it).

    Examples
    --------
    >>> install()
    >>> sum(isinstance(f, _Finder) for f in sys.meta_path)
    1
    """
    if not any(isinstance(f, _Finder) for f in sys.meta_path):
        sys.meta_path.append(_Finder())
