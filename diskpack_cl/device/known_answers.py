"""The known answers of every device program, and the child process that checks them.

:mod:`diskpack_cl.device.checks` starts ``python -m diskpack_cl.device.known_answers``
for a device; here each program runs on small fixed inputs through its
stage and is compared with numpy and scipy (see that module for what the
verdicts do).  Kept apart from it so that the stages, which read verdicts,
are not imported by what reads them.

Examples
--------
>>> sorted(CHECKS) == sorted([*PROGRAMS, "checks_wide_probe"])
True
"""

from __future__ import annotations

import json
import os
import time
import warnings

import numpy as np

from .context import context_unchecked
from .programs import BuildError
from .checks import PROGRAMS, Verdict, use_verdict, verdict_of

__all__ = ["CHECKS", "check_device", "main"]

def _child(address, wide, salt, stems):
    """Run each check in turn, a line of JSON before (``start``) and after each."""
    import pyopencl as cl

    ip, idev = address
    ctx = cl.Context([cl.get_platforms()[ip].get_devices()[idev]])
    # what every stage built here reads (verdict_of): the switches under check
    use_verdict(Verdict.trusting(ctx.devices[0], wide, CHECKS, salt))
    fault = dict(item.split("=", 1) for item in os.environ.get("DISKPACK_CL_CHECK_FAULT", "").split(",")
                 if "=" in item)
    for stem in stems:
        print(json.dumps({"start": stem}), flush=True)
        t0 = time.perf_counter()
        retry = False
        try:
            _inject(fault.get(stem))
            why = CHECKS[stem](ctx, fault.get(stem) == "wrong")
        except (cl.Error, KeyError, BuildError) as exc:   # a build that failed or came back without kernels
            why, retry = f"{type(exc).__name__}: {str(exc).strip().splitlines()[-1][:200] if str(exc).strip() else ''}", True
        except Exception as exc:  # noqa: BLE001 - any failure of a check is its verdict
            why = f"{type(exc).__name__}: {str(exc)[:200]}"
        print(json.dumps({"stem": stem, "ok": why is None, "why": why or "", "retry": retry,
                          "seconds": round(time.perf_counter() - t0, 3), "salt": salt}), flush=True)


def _inject(fault):
    """The checks' own fault injection (``DISKPACK_CL_CHECK_FAULT=stem=crash|hang|wrong``):
    what a broken driver does, so that tests can see each refused."""
    if fault == "crash":   # a real invalid read, as a miscompiled kernel makes
        import ctypes

        ctypes.string_at(0)
    if fault == "hang":
        while True:
            time.sleep(60)


def _differ(name, got, want, atol):
    """None where `got` matches `want` to `atol` (NaNs alike), else a line saying how far off."""
    got, want = np.asarray(got, np.float64), np.asarray(want, np.float64)
    if got.shape != want.shape:
        return f"{name}: shape {got.shape}, expected {want.shape}"
    bad = ~((np.isnan(got) & np.isnan(want)) | (np.abs(got - want) <= atol))
    if bad.any():
        err = np.nanmax(np.where(bad, np.abs(got - want), 0)) if np.isfinite(got[bad]).all() else np.inf
        return f"{name}: {int(bad.sum())} of {got.size} values off by up to {err:.3g} (tolerance {atol:g})"
    return None


def _cases2d():
    """Small 2D inputs with the code paths in them: random sites, a lattice (ties), sites on
    the borders and corners, and weights; a torus and a rectangle."""
    from ..domain import Domain

    rng = np.random.default_rng(20261205)
    lattice = (np.stack(np.meshgrid(np.arange(6), np.arange(5)), -1).reshape(-1, 2) + 0.5) / (6, 5)
    border = np.array([[0.0, 0.0], [1.0, 0.3], [0.5, 1.0], [0.0, 0.71], [1.0, 1.0]])
    rect = Domain.rect(40.0, 30.0)
    pts = np.vstack([rng.random((40, 2)), border]) * (40.0, 30.0)
    w = (rng.random(len(pts)) * 2.0) ** 2
    return [(Domain.torus(), rng.random((60, 2)), None),
            (Domain.torus(), lattice, None),
            (rect, pts, w),
            (rect, lattice * (40.0, 30.0), None)]


def _power_gap(domain, shape, pts, w, labels):
    """How much worse, in power distance, each grid cell's label is than its best site."""
    from ..labels import grid_centers

    c = grid_centers(domain, shape).reshape(-1, 1, 2)
    d = c - pts[None]
    if domain.periodic:
        d -= np.rint(d / (domain.width, domain.height)) * (domain.width, domain.height)
    pw = (d ** 2).sum(-1) - (0.0 if w is None else w[None])
    lab = labels.reshape(-1)
    if lab.min() < 0 or lab.max() >= len(pts):
        return np.inf
    return float((pw[np.arange(len(lab)), lab] - pw.min(1)).max())


def _check_raster_labels(ctx, wrong):
    from .raster import PowerRaster

    for domain, pts, w in _cases2d():
        scale2 = max(domain.width, domain.height) ** 2
        for shape in ((37, 45), (16, 8), (3, 70)):   # partial tiles, one full tile, thin
            for layout in ("tile", "item"):
                for lanes in ((16, 8) if verdict_of(ctx).wide else (8,)):
                    pr = PowerRaster(domain, shape, ctx, layout=layout, lanes=lanes)
                    lab = pr.compute(pts, w, distance=False).labels.copy() + int(wrong)
                    gap = _power_gap(domain, shape, pts, w, lab)
                    if not gap <= 1e-5 * scale2:
                        return (f"{layout} layout, {lanes} lanes, {shape}: labels not the least power "
                                f"distance (off by {gap:.3g})")
    return None


def _check_raster_mic(ctx, wrong):
    from .raster import PowerRaster

    for domain, pts, w in _cases2d():
        pr = PowerRaster(domain, (41, 37), ctx, layout="item")
        est = pr.compute(pts, w)
        lab, dist = est.labels.copy(), est.dist.copy()
        want = np.full(len(pts), -1.0)
        np.maximum.at(want, lab.ravel(), dist.ravel())
        if (why := _differ("cell maxima", est.radii + wrong, want, 0.0)) is not None:
            return why
    return None


def _check_raster_sums(ctx, wrong):
    from ..labels import cell_centroids
    from .raster import PowerRaster

    rng = np.random.default_rng(7)
    for domain, pts, w in _cases2d():
        for shape in ((37, 45), (16, 8)):
            density = rng.random(shape)
            for layout in ("tile", "item"):
                if "cl_khr_int64_base_atomics" not in ctx.devices[0].extensions:
                    return None   # the host sums (nothing of cell_sums runs on this device)
                pr = PowerRaster(domain, shape, ctx, layout=layout)
                lab = pr.compute(pts, w, distance=False).labels.copy()
                got = pr.centroids(pts, w, density)
                want = cell_centroids(lab, pts, density, domain)
                scale = max(domain.width, domain.height)
                for name, g, h, tol in (("mass", got[1], want[1], 1e-5 * density.size),
                                        ("centroids", got[0], want[0], 1e-4 * scale)):
                    if (why := _differ(f"{layout} {shape} {name}", g + wrong, h, tol)) is not None:
                        return why
    return None


def _check_cells(ctx, wrong):
    from .cells import CellMIC
    from ..geometry import exact_mic

    for domain, pts, w in _cases2d():
        got = CellMIC(domain, ctx).solve(pts, w, certify=False)
        want = exact_mic(pts, w, domain)
        if (why := _differ("MIC radii", got.radii + wrong, want.radii, 1e-9)) is not None:
            return why
    return None


def _check_cells_nearest(ctx, wrong):
    from scipy.spatial import cKDTree

    from .cells import CellMIC
    from ..domain import Domain

    rng = np.random.default_rng(3)
    for pts in (rng.random((300, 2)), np.vstack([rng.random((50, 2)), [[0.0, 0.0], [0.999, 0.999]]])):
        got = CellMIC(Domain.torus(), ctx).nearest(pts)
        want = cKDTree(pts, boxsize=1.0).query(pts, k=2)[0][:, 1]
        if (why := _differ("nearest distances", got + wrong, want, 1e-14)) is not None:
            return why
    return None


def _check_cells3(ctx, wrong):
    from .cells3 import CellMIC3, Domain3, exact_mis

    rng = np.random.default_rng(5)
    lattice = (np.stack(np.meshgrid(*[np.arange(4)] * 3), -1).reshape(-1, 3) + 0.5) / 4
    for domain, X in ((Domain3.torus(), rng.random((150, 3))), (Domain3.torus(), lattice),
                      (Domain3.box(2.0, 1.0, 1.5), rng.random((120, 3)) * (2.0, 1.0, 1.5))):
        got = CellMIC3(domain, ctx).solve(X, certify=False)
        if (why := _differ("sphere radii", got.radii + wrong, exact_mis(X, domain).radii, 1e-9)) is not None:
            return why
    return None


def _check_parallel_darts(ctx, wrong):
    from ..parallel_darts import parallel_darts

    got = parallel_darts(3000, seed=11, device=ctx)
    want = parallel_darts(3000, seed=11, device=False)
    return _differ("dart points", got + wrong, want, 0.0)


def _check_blur(ctx, wrong):
    from .blur import DeviceBlur
    from ..radii import gaussian_blur

    rng = np.random.default_rng(9)
    blur = DeviceBlur(ctx)
    for shape, sigma in (((37, 53), 1.5), ((5, 3), 2.5), ((1, 40), 0.7), ((24, 16), 4.0)):
        img = rng.random(shape)
        if (why := _differ(f"blur {shape} sigma {sigma}", blur(img, sigma) + wrong,
                           gaussian_blur(img, sigma), 1e-12)) is not None:
            return why
    return None


def _check_checks_wide_probe(ctx, wrong):
    import pyopencl as cl

    from .programs import build_program

    k = build_program(ctx, "checks_wide_probe", verdict_of(ctx).defines("checks_wide_probe"))["wide_probe"]
    queue, mf = cl.CommandQueue(ctx), cl.mem_flags
    x = np.linspace(-3.3, 4.1, 8)
    f = np.linspace(-1.25, 2.5, 16).astype(np.float32)
    out, fout = np.zeros(16), np.zeros(16, np.float32)
    b_in, b_f = (cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a) for a in (x, f))
    b_out, b_fout = cl.Buffer(ctx, mf.WRITE_ONLY, out.nbytes), cl.Buffer(ctx, mf.WRITE_ONLY, fout.nbytes)
    k(queue, (1,), None, b_in, b_f, b_out, b_fout)
    cl.enqueue_copy(queue, out, b_out)
    cl.enqueue_copy(queue, fout, b_fout)
    want = np.concatenate([np.rint(x * 1.5), f[:8].astype(np.float64)])
    return (_differ("double8 builtins", out + wrong, want, 0.0)
            or _differ("float16 builtins", fout, np.where(np.arange(16) >= 7, 0.0, f), 0.0))


CHECKS = {name[len("_check_"):]: fn for name, fn in globals().items() if name.startswith("_check_")}
assert set(CHECKS) == set(PROGRAMS) | {"checks_wide_probe"}



def check_device(device=None, *, refresh=False):
    """The :class:`~diskpack_cl.device.checks.Verdict` of a device string's device (see
    :func:`diskpack_cl.get_context`), the checks run now where none is cached (or with `refresh`).

    Examples
    --------
    >>> check_device().core_failure() is None
    True
    """
    return verdict_of(context_unchecked(device), refresh=refresh)


def main(argv=None):
    """The child's entry: ``python -m diskpack_cl.device.known_answers --child P:D --wide W --salt S STEM...``.

    It prints a line of JSON before and after each check (see :mod:`diskpack_cl.device.checks`).

    Examples
    --------
    >>> main(["--child", "0:0", "--wide", "0", "nonsense"])  # doctest: +SKIP
    """
    import argparse

    ap = argparse.ArgumentParser(prog="python -m diskpack_cl.device.known_answers")
    ap.add_argument("--child", required=True)
    ap.add_argument("--wide", type=int, required=True)
    ap.add_argument("--salt", type=int, default=0)
    ap.add_argument("stems", nargs="+", choices=list(CHECKS))
    args = ap.parse_args(argv)
    ip, idev = (int(x) for x in args.child.split(":"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _child((ip, idev), args.wide, args.salt, args.stems)


if __name__ == "__main__":
    # the package's own module, not this __main__ copy: the stages read its verdict
    from diskpack_cl.device.known_answers import main as _main

    _main()
