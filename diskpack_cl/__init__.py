"""Poisson disk sampling and image stippling by disk packing.

OpenCL kernels label a fine grid with the power diagram and estimate each
cell's maximal inscribed circle; numpy/scipy refine every circle exactly in
float64, so returned points and radii are certified.
"""

from importlib.metadata import PackageNotFoundError
from importlib.metadata import version as _version

from .domain import Domain
from .geometry import CertificateError, certify_disks, exact_mic
from .measures import normalized_radius
from .relax import RadiusResult, RelaxOptions, RelaxResult, max_points_for_radius, relax_poisson
from .poisson import PoissonDiskResult, poisson_disk
from .qmc import PoissonDisk
from .sampling import dart_throwing, random_points
from ._device import NoOpenCLError, describe, get_context, list_devices
from .dithering import error_diffusion
from .schedule import StippleOptions
from .stipple import StippleResult, stipple
from .export import WriteOptions, read_stipple, write_stipple
from .image import ToneOptions, load_gray, sample_image_path
from .multipen import ColorStippleResult, stipple_colors

__all__ = [
    "Domain", "CertificateError", "certify_disks", "exact_mic", "normalized_radius",
    "NoOpenCLError", "describe", "get_context", "list_devices",
    "RelaxOptions", "RelaxResult", "relax_poisson", "RadiusResult", "max_points_for_radius", "dart_throwing", "random_points",
    "PoissonDisk", "PoissonDiskResult", "poisson_disk",
    "StippleOptions", "StippleResult", "error_diffusion", "stipple", "read_stipple",
    "write_stipple", "WriteOptions", "ToneOptions", "load_gray", "sample_image_path",
    "ColorStippleResult", "stipple_colors",
]

try:  # the installed distribution's version (pyproject.toml), read once
    __version__ = _version("diskpack_cl")
except PackageNotFoundError:  # pragma: no cover - a source tree that was never installed
    __version__ = "0+unknown"
