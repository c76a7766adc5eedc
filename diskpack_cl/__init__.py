"""Poisson disk sampling and image stippling by disk packing.

OpenCL kernels label a fine grid with the power diagram and estimate each
cell's maximal inscribed circle; numpy/scipy refine every circle exactly in
float64, so returned points and radii are certified.
"""

from importlib.metadata import PackageNotFoundError
from importlib.metadata import version as _version

from .domain import Domain
from .geometry import certify_disks, exact_mic
from .measures import normalized_radius
from .relax import RadiusResult, RelaxResult, max_points_for_radius, relax_poisson
from .poisson import PoissonDisk, PoissonDiskResult, poisson_disk
from .sampling import dart_throwing, random_points
from ._device import NoOpenCLError, describe, get_context, list_devices
from .dithering import error_diffusion
from .stipple import StippleResult, stipple
from .export import read_stipple, write_stipple
from .image import load_gray, sample_image_path

__all__ = [
    "Domain", "certify_disks", "exact_mic", "normalized_radius",
    "NoOpenCLError", "describe", "get_context", "list_devices",
    "RelaxResult", "relax_poisson", "RadiusResult", "max_points_for_radius", "dart_throwing", "random_points",
    "PoissonDisk", "PoissonDiskResult", "poisson_disk",
    "StippleResult", "error_diffusion", "stipple", "read_stipple", "write_stipple",
    "load_gray", "sample_image_path",
]

try:  # the installed distribution's version (pyproject.toml), read once
    __version__ = _version("diskpack_cl")
except PackageNotFoundError:  # pragma: no cover - a source tree that was never installed
    __version__ = "0+unknown"
