"""The certificate of a large stippling: seconds of :func:`~diskpack_cl.radii.certified_k`.

Usage: python benchmarks/certificate.py RESULT.npz [--repeats 5]

`RESULT.npz` is a stippling's ``.npz`` (``diskpack stipple ... -o RESULT.npz``; the
1M dots of ``stipple_large.py --command`` are the issue's case): its dots and base
radii go through :func:`~diskpack_cl.radii.certified_k` as the run's last stage
makes them (the largest valid k, then :func:`~diskpack_cl.geometry.certify_disks`
of its disks), each repeat beside an anchor of one core, ``np.sort`` of a million
uniform float64 numbers (seed 0).  Prints the medians of the seconds and of the
ratio to the anchor of the same repeat, and checks that every repeat gives the
``.npz``'s k and certificate.  Run it with the tree before a change and the tree
after (``PYTHONPATH``), alternately, and compare the ratios.
"""

import argparse
import time

import numpy as np

from diskpack_cl.domain import Domain
from diskpack_cl.radii import certified_k


def one_repeat(points, base, width, height, anchor_values):
    """``(certificate seconds, anchor seconds, (k, certificate))`` of one repeat."""
    t = time.perf_counter()
    np.sort(anchor_values)
    anchor = time.perf_counter() - t
    t = time.perf_counter()
    k, _, cert = certified_k(points, base, width, height, Domain.rect(width, height))
    return time.perf_counter() - t, anchor, (k, cert)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("result")
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    with np.load(args.result) as f:
        points, base = f["points"], f["base_radii"]
        width, height, k_saved = int(f["width"]), int(f["height"]), float(f["k"])
        saved = (bool(f["certificate_valid"]), float(f["certificate_min_gap"]),
                 int(f["certificate_pairs_checked"]))
    anchor_values = np.random.default_rng(0).random(1_000_000)
    secs, anchors = [], []
    for _ in range(args.repeats):
        s, a, (k, cert) = one_repeat(points, base, width, height, anchor_values)
        if k != k_saved or (cert.valid, cert.min_gap, cert.pairs_checked) != saved:
            raise SystemExit(f"not the saved result: k {k} against {k_saved}, {cert} against {saved}")
        secs.append(s)
        anchors.append(a)
    secs, anchors = np.array(secs), np.array(anchors)
    print(f"n={len(points)} on {width}x{height}: certified_k median {np.median(secs):.3f} s, "
          f"anchor {np.median(anchors) * 1e3:.1f} ms, ratio to the anchor "
          f"{np.median(secs / anchors):.2f} ({args.repeats} repeats, the saved k and certificate)")


if __name__ == "__main__":
    main()
