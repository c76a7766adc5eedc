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

#: Output rows of a work item of the column pass (blur.cl's ``ROWS``), whose taps it
#: shares; 8 was the fastest on both CPU builds (docs/guide/performance.md).
COLUMN_ROWS = 8


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
    outputs of a row a work item in double vectors (the column pass takes
    :data:`COLUMN_ROWS` such runs, one under the other, sharing their taps), and
    every output is summed in the order and rounding of scipy's symmetric
    correlation.

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
        k = self.program("blur", {"ROWS": COLUMN_ROWS})
        self._passes = (k["blur_columns"], k["blur_rows"])

    def __call__(self, image, sigma):
        """The blurred float64 image (a new array; `image` is not changed)."""
        return self.many(image, [sigma])[0]

    def many(self, image, sigmas):
        """``[self(image, s) for s in sigmas]``, with `image` sent to the device once (the
        stage's blurs of one darkness band). On a CPU the kernels read `image` and write the
        blurs where they are (no copy either way)."""
        image = np.ascontiguousarray(image, np.float64)
        if image.ndim != 2 or image.size == 0:
            raise ValueError(f"DeviceBlur blurs non-empty 2-D images, got shape {image.shape}")
        H, W = image.shape
        src, tmp = self._input(image), self.buffer("tmp", image.nbytes)
        outs = [np.empty_like(image) for _ in sigmas]
        for sigma, blurred in zip(sigmas, outs):
            if not float(sigma) > 1e-15:   # as scipy: no blur
                np.copyto(blurred, image)
                continue
            w = gaussian_weights(sigma)
            b_w = cl.Buffer(self.ctx, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=w)
            dst = self._output(blurred)
            shape = (np.int32(len(w) // 2), np.int32(W), np.int32(H))
            self._passes[0](self.queue, (-(-W // 8), -(-H // COLUMN_ROWS)), None, src, tmp, b_w,
                            *shape)
            self._passes[1](self.queue, (-(-W // 8), H), None, tmp, dst, b_w, *shape)
            self._read(blurred, dst)
        self.queue.finish()   # the maps and reads are done: the arrays hold the blurs
        return outs

    def _input(self, image):
        """The input's buffer: on a CPU the host's array itself."""
        mf = cl.mem_flags
        if self.is_cpu:
            return cl.Buffer(self.ctx, mf.READ_ONLY | mf.USE_HOST_PTR, hostbuf=image)
        return cl.Buffer(self.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=image)

    def _output(self, out):
        """The buffer the row pass writes `out` to: on a CPU `out` itself (no copy back)."""
        if self.is_cpu:
            return cl.Buffer(self.ctx, cl.mem_flags.WRITE_ONLY | cl.mem_flags.USE_HOST_PTR, hostbuf=out)
        return self.buffer("dst", out.nbytes)

    def _read(self, out, dst):
        """Queue what brings the blur in `dst` to the host array `out`."""
        if self.is_cpu:   # mapped and unmapped: the driver makes `out` hold the writes
            mapped, _ = cl.enqueue_map_buffer(self.queue, dst, cl.map_flags.READ, 0, out.shape,
                                              out.dtype, is_blocking=False)
            mapped.base.release(self.queue)
        else:
            cl.enqueue_copy(self.queue, out, dst, is_blocking=False)

