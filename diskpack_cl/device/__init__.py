"""The device layer: everything that talks to OpenCL.

- :mod:`~diskpack_cl.device.context`: which device runs (``device=``, ``DISKPACK_DEVICE``,
  ``PYOPENCL_CTX``), the platforms, work-group sizes;
- :mod:`~diskpack_cl.device.programs`: the kernel sources (``kernels/``), each program built
  once per context and switches;
- :mod:`~diskpack_cl.device.checks` and :mod:`~diskpack_cl.device.known_answers`: a
  device's trust, earned program by program on known inputs;
- :mod:`~diskpack_cl.device.stage`: ``DeviceStage``, the base of every stage below;
- the stages, each with the kernels named for it: :mod:`~diskpack_cl.device.raster`
  (``raster_*.cl``), :mod:`~diskpack_cl.device.cells` (``cells*.cl``),
  :mod:`~diskpack_cl.device.cells3` (``cells3.cl``), :mod:`~diskpack_cl.device.blur`
  (``blur.cl``); the dart grid of :mod:`diskpack_cl.parallel_darts` (``parallel_darts.cl``).

Nothing above this layer builds a program or touches a queue.
"""

__all__ = []   # the folder's API is its modules'
