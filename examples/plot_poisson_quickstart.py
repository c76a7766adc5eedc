"""
Poisson disk quickstart
=======================

The shortest way to a blue-noise set: ask for a minimum distance (scipy's
``radius``) or a count. The result says how even it is: ``rho`` is the
normalized Poisson disk radius (1 is the hexagonal packing; dart throwing
gives about 0.74, the relaxation reaches 0.8 by default).
"""

import matplotlib.pyplot as plt

from diskpack_cl import PoissonDisk, poisson_disk

res = poisson_disk(min_distance=0.04, seed=0)        # the unit torus
print(f"{len(res.points)} points, rho {res.rho:.3f}, reached: {res.reached}")

# scipy.stats.qmc's engine, for code written against scipy:
engine = PoissonDisk(2, radius=0.04, rng=0)
sample = engine.fill_space()

fig, (a, b) = plt.subplots(1, 2, figsize=(8, 4))
a.plot(res.points[:, 0], res.points[:, 1], ".", ms=3, color="k")
a.set_title("poisson_disk(min_distance=0.04)")
b.plot(sample[:, 0], sample[:, 1], ".", ms=3, color="k")
b.set_title("PoissonDisk(2, radius=0.04).fill_space()")
for ax in (a, b):
    ax.set_aspect("equal")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
fig.tight_layout()
plt.show()
