"""Jobs: one item, many items, one large picture in parts.

- :mod:`~diskpack_cl.jobs.items`: what one item does (``plan_stipple``, ``stipple_item``,
  ``write_stipple_outputs``, ...), the one implementation for a single input and for every
  batch item; its public names are this package's too;
- :mod:`~diskpack_cl.jobs.executors`: items in this process, in spawned workers or on Dask;
- :mod:`~diskpack_cl.jobs.batch`: the public batch calls (``stipple_many``, ...);
- :mod:`~diskpack_cl.jobs.tiles`: one large picture in tiles.
"""

import importlib

__all__ = []   # the folder's API is its modules' (the items' names load on demand)


def __getattr__(name):
    # the items' names, loaded when first asked for: `diskpack poisson` never imports them
    items = importlib.import_module(".items", __name__)
    if name in items.__all__:
        return getattr(items, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
