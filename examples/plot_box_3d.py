"""
Poisson disk sets in a box and in 3D
====================================

:func:`diskpack_cl.poisson_disk` makes a set by a count or by a minimum
distance (scipy's ``radius``), on the unit torus or in a box with exact
walls, in 2D or 3D. In a box every point moves to the centre of the largest
disk of its Voronoi cell clipped to the box; in 3D to the centre of the
largest sphere of its 3D Voronoi cell.
"""

import matplotlib.pyplot as plt

from diskpack_cl import poisson_disk

box = poisson_disk(min_distance=0.05, box=(2, 1), seed=0)
print(f"2 x 1 box: {len(box.points)} points, smallest distance {box.min_distance:.4f}")
cube = poisson_disk(600, box=(1, 1, 1), dim=3, seed=0)
print(f"unit cube: {len(cube.points)} points, rho {cube.rho:.3f}")

fig = plt.figure(figsize=(10, 4))
a = fig.add_subplot(1, 2, 1)
a.plot(box.points[:, 0], box.points[:, 1], ".", ms=3, color="k")
a.set_aspect("equal")
a.set_title(f"2 x 1 box, min distance {box.min_distance:.3f}")
b = fig.add_subplot(1, 2, 2, projection="3d")
p = cube.points
b.scatter(p[:, 0], p[:, 1], p[:, 2], s=4, c=p[:, 2], cmap="viridis")
b.set_title(f"3D, {len(p)} points, rho {cube.rho:.2f}")
fig.tight_layout()
plt.show()
