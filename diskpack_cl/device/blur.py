"""Gaussian blurs of large images on an OpenCL device, with scipy.ndimage's values.

The stippling's fields are blurs of the picture's darkness (the radius
field, the detail weight, the ink); at millions of pixels scipy's
one-core-at-a-time correlation is most of the time a run spends making
them.  :class:`DeviceBlur` makes the same blur with the kernels of
``kernels/blur.cl``, summed in scipy's order.
"""

from __future__ import annotations

import numpy as np
import pyopencl as cl

from .stage import DeviceStage
from ..radii import TRUNCATE

__all__ = ["DeviceBlur", "gaussian_weights"]


def gaussian_weights(sigma):
    """The 2 r + 1 weights of scipy.ndimage's Gaussian of `sigma` (``r = int(4 sigma + 0.5)``).

    Examples
    --------
    >>> w = gaussian_weights(1.0)
    >>> len(w), round(float(w.sum()), 12)
    (9, 1.0)
    """
    r = int(TRUNCATE * float(sigma) + 0.5)
    x = np.arange(-r, r + 1)
    phi = np.exp(-0.5 / (float(sigma) * float(sigma)) * x ** 2)
    return phi / phi.sum()


class DeviceBlur(DeviceStage):
    """``scipy.ndimage.gaussian_filter(image, sigma, mode="reflect")`` on an OpenCL device
    with float64, as :func:`~diskpack_cl.radii.gaussian_blur` makes it on the host.

    Both passes (along the columns, then the rows) run on the device, eight
    outputs a work item in double vectors, and every output is summed in the
    order and rounding of scipy's symmetric correlation.

    Parameters
    ----------
    device : pyopencl.Context, str or None
        As :func:`diskpack_cl.device.context.get_context`.

    Raises
    ------
    RuntimeError
        The device has no float64 (:class:`~diskpack_cl.device.checks.UntrustedProgram`:
        the program failed its check there).

    Examples
    --------
    >>> from diskpack_cl.radii import gaussian_blur
    >>> a = np.random.default_rng(0).random((40, 30))
    >>> bool(np.allclose(DeviceBlur()(a, 1.5), gaussian_blur(a, 1.5), rtol=0, atol=1e-12))
    True
    """

    def __init__(self, device=None):
        super().__init__(device, fp64=True)
        k = self.program("blur")
        self._passes = (k["blur_columns"], k["blur_rows"])
        self._pass_buffers = None

    def __call__(self, image, sigma):
        """The blurred float64 image (a new array; `image` is not changed)."""
        image = np.ascontiguousarray(image, np.float64)
        if image.ndim != 2 or image.size == 0:
            raise ValueError(f"DeviceBlur blurs non-empty 2-D images, got shape {image.shape}")
        if not float(sigma) > 1e-15:   # as scipy: no blur
            return image.copy()
        H, W = image.shape
        w = gaussian_weights(sigma)
        r = len(w) // 2
        src, tmp, dst = self._buffers(image)
        b_w = cl.Buffer(self.ctx, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=w)
        size = (-(-W // 8), H)
        for kernel, (a, b) in zip(self._passes, ((src, tmp), (tmp, dst))):
            kernel(self.queue, size, None, a, b, b_w, np.int32(r), np.int32(W), np.int32(H))
        out = np.empty_like(image)
        cl.enqueue_copy(self.queue, out, dst)
        return out

    def _buffers(self, image):
        """The input's buffer (the host's array itself on a CPU), and the pass buffers,
        kept from call to call while the size stays (the bands of a picture)."""
        mf = cl.mem_flags
        if self.is_cpu:
            src = cl.Buffer(self.ctx, mf.READ_ONLY | mf.USE_HOST_PTR, hostbuf=image)
        else:
            src = cl.Buffer(self.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=image)
        if self._pass_buffers is None or self._pass_buffers[0].size < image.nbytes:
            self._pass_buffers = tuple(cl.Buffer(self.ctx, mf.READ_WRITE, image.nbytes) for _ in range(2))
        return (src,) + self._pass_buffers
