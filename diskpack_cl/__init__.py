"""Poisson disk sampling and image stippling by disk packing.

OpenCL kernels label a fine grid with the power diagram and estimate each
cell's maximal inscribed circle; numpy/scipy refine every circle exactly in
float64, so returned points and radii are certified.
"""

import importlib
import sys
import types

from . import _version

__version__ = _version.__version__

#: The public names of each module.  The package loads a module when one of its names is
#: first asked for (PEP 562): ``diskpack poisson`` then never loads the stippling stack
#: or scipy.stats (PoissonDisk's base class), which take seconds to import.
_PUBLIC = {
    "domain": ["Domain"],
    "geometry": ["CertificateError", "certify_disks", "exact_mic"],
    "measures": ["normalized_radius"],
    "device.context": ["NoOpenCLError", "describe", "get_context", "list_devices", "list_platforms"],
    "relax": ["RelaxOptions", "RelaxResult", "relax_poisson", "RadiusResult",
              "max_points_for_radius"],
    "sampling": ["dart_throwing", "random_points"],
    "poisson": ["PoissonOptions", "PoissonDiskResult", "poisson_disk"],
    "qmc": ["PoissonDisk"],
    "schedule": ["StippleOptions"],
    "stipple": ["StippleResult", "stipple"],
    "dithering": ["error_diffusion"],
    "drawing.write_options": ["WriteOptions"],
    "drawing.writers": ["read_stipple", "write_stipple"],
    "image": ["ToneOptions", "load_gray", "sample_image_path"],
    "multipen": ["ColorStippleResult", "stipple_colors"],
    "preview": ["preview"],
}
_HOMES = {name: module for module, names in _PUBLIC.items() for name in names}
__all__ = list(_HOMES)


class _Package(types.ModuleType):
    """The package's module: a submodule never shadows the public name it shares
    (importing ``diskpack_cl.stipple`` leaves ``diskpack_cl.stipple`` the function)."""

    def __setattr__(self, name, value):
        if not (name in _HOMES and isinstance(value, types.ModuleType)):
            super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
importlib.import_module(".moved", __name__).install()


def __getattr__(name):
    if name not in _HOMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{_HOMES[name]}", __name__), name)
    globals()[name] = value   # loaded once
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))


