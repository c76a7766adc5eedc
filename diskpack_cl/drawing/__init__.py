"""Drawing a stippling: the files it becomes and the paper it goes on.

- :mod:`~diskpack_cl.drawing.writers`: ``WriteOptions`` and ``write_stipple``, the one
  route of every output (SVG, PNG, NPZ, CSV), mono and colour;
- :mod:`~diskpack_cl.drawing.color_writers`: the colour SVG (a layer per pen) and PNG;
- :mod:`~diskpack_cl.drawing.page`: what both share: the page layout, the SVG's elements and
  grid, ink and plot time;
- :mod:`~diskpack_cl.drawing.readers`: ``read_stipple`` and the checks the writers share;
- :mod:`~diskpack_cl.drawing.plotters`: vpype's device profiles;
- :mod:`~diskpack_cl.drawing.overlap`: drawn dots that must not touch;
- :mod:`~diskpack_cl.drawing.pen_path`: the order the pen visits the dots.
"""

__all__ = []   # the folder's API is its modules'
