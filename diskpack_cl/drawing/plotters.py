"""What a plotter reaches on the page: the plotting areas of vpype's device profiles.

vpype's ``write --device NAME`` (HPGL) moves the page onto the device's
paper (turned when the orientations differ, turned over for ``rotate_180``),
converts it to plotter units from the paper's origin and crops everything
outside the device's ``x_range`` x ``y_range``: a dot there is lost or cut.
:func:`plotting_area` inverts those steps, so a picture laid out inside it
(``--plotter NAME``, :func:`diskpack_cl.drawing.writers.svg_layout`) keeps every dot.
The profiles are vpype's (its bundled ``vpype_config.toml`` and the user's
``~/.vpype.toml``); vpype is the ``vpype`` extra.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

from ..extras import install_command

__all__ = ["area_text", "plotter_config", "plotting_area"]

MM_PER_PX = 25.4 / 96   # vpype's unit is the CSS pixel
# a page and a paper of one size, printed in mm and read back in vpype's pixels
_SAME_MM = 0.5


def plotter_config(name):
    """vpype's profile of the plotter ``name`` (``vpype.PlotterConfig``).

    Raises
    ------
    ValueError
        vpype is not installed, its profiles are not TOML, the profile of
        ``name`` lacks a field or holds one vpype cannot read (the message
        names the file), or vpype knows no device ``name`` (the message
        lists those it knows).

    Examples
    --------
    >>> plotter_config("hp7475a").pen_count
    6
    """
    try:
        import vpype  # the optional vpype extra
    except ImportError:
        raise ValueError("--plotter reads vpype's device profiles: "
                         + install_command("vpype")) from None
    except ValueError as exc:   # vpype reads the user's profiles as it is imported
        raise ValueError(f"vpype's profiles in {_user_profiles()} are not valid TOML: "
                         f"{exc}") from None
    try:
        config = vpype.config_manager.get_plotter_config(name)
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        what = f"it has no {exc}" if isinstance(exc, KeyError) else str(exc)
        raise ValueError(f"vpype's profile of the plotter {name!r} in {_profile_file(name)} is "
                         f"unreadable: {what}") from None
    if config is None:
        known = ", ".join(sorted(vpype.config_manager.get_plotter_list()))
        raise ValueError(f"plotter must be a device of vpype's profiles ({known}), got {name!r}")
    return config


def _user_profiles():
    """The user's vpype profiles, which vpype reads over its own."""
    return os.path.expanduser("~/.vpype.toml")


def _profile_file(name):
    """The file vpype read the plotter `name`'s profile from: the user's where it has one."""
    import tomli  # vpype's TOML reader
    import vpype.config

    try:
        with open(_user_profiles(), "rb") as fh:
            if name in tomli.load(fh).get("device", {}):
                return _user_profiles()
    except (OSError, ValueError):
        pass
    return str(Path(vpype.config.__file__).parent / "vpype_config.toml")


def area_text(area):
    """A rectangle ``(x0, y0, x1, y1)`` of the page, in words.

    Examples
    --------
    >>> area_text((4.0, 10.0, 196.14, 284.7))
    'x 4 to 196.1 mm, y 10 to 284.7 mm'
    """
    x0, y0, x1, y1 = (round(v, 1) for v in area)
    return f"x {x0:g} to {x1:g} mm, y {y0:g} to {y1:g} mm"


def _paper(config, page_mm):
    """The device's paper of the page's size (either way round), else its flexible one."""
    w, h = sorted(page_mm)
    for pc in config.paper_configs:
        if pc.paper_size is not None:
            pw, ph = sorted(v * MM_PER_PX for v in pc.paper_size)
            if abs(pw - w) <= _SAME_MM and abs(ph - h) <= _SAME_MM:
                return pc
    flexible = [pc for pc in config.paper_configs if pc.paper_size is None]
    if not flexible:
        sizes = ", ".join(f"{pc.name} ({pc.paper_size[0] * MM_PER_PX:.0f}x"
                          f"{pc.paper_size[1] * MM_PER_PX:.0f} mm)" for pc in config.paper_configs)
        raise ValueError(f"the plotter {config.name} takes no {page_mm[0]:g}x{page_mm[1]:g} mm "
                         f"paper; its papers: {sizes}")
    return flexible[0]


def plotting_area(plotter, page_mm):
    """The part of a page that ``vpype write --device PLOTTER`` plots, in page mm.

    As vpype writes a page of this size to the device's paper of the same
    size (``--page-size``, ``--landscape`` for a landscape page: what vpype
    infers from the page when not given).

    Parameters
    ----------
    plotter : str
        A device of vpype's profiles (``hp7475a``, ...).
    page_mm : (float, float)
        Width and height of the page.

    Returns
    -------
    (x0, y0, x1, y1) : tuple of float
        The plotted rectangle, x right and y down from the page's top-left
        corner, within the page.

    Examples
    --------
    The HP 7475A reaches to 4 mm from the right side of a portrait A4 and
    to 12 mm from its foot:

    >>> [round(v, 1) for v in plotting_area("hp7475a", (210, 297))]
    [4.0, 10.0, 196.1, 284.7]
    """
    config = plotter_config(plotter)
    pc = _paper(config, page_mm)
    try:
        area = _area(config, pc, page_mm)
    except TypeError as exc:
        raise ValueError(f"vpype's profile of the plotter {plotter!r} in "
                         f"{_profile_file(plotter)} is unreadable: its paper {pc.name!r} has "
                         f"x_range {pc.x_range!r}, y_range {pc.y_range!r} ({exc})") from None
    x0, y0, x1, y1 = area
    if not (config.plotter_unit_length > 0 and x0 < x1 and y0 < y1
            and all(math.isfinite(v) for v in area)):
        raise ValueError(f"vpype's profile of the plotter {plotter!r} in {_profile_file(plotter)} "
                         f"leaves no plotting area on a {page_mm[0]:g}x{page_mm[1]:g} mm page "
                         f"({area_text(area)}; its paper {pc.name!r}: x_range {pc.x_range}, "
                         f"y_range {pc.y_range}, plotter_unit_length "
                         f"{config.plotter_unit_length:g} px)")
    return area


def _area(config, pc, page_mm):
    """:func:`plotting_area` of the device's paper `pc`, unchecked."""
    page_w, page_h = page_mm
    paper_w, paper_h = ((v * MM_PER_PX for v in pc.paper_size) if pc.paper_size is not None
                        else page_mm)
    if pc.paper_orientation is not None and (pc.paper_orientation == "landscape") != (paper_w > paper_h):
        paper_w, paper_h = paper_h, paper_w
    if pc.x_range is None or pc.y_range is None:
        return (0.0, 0.0, float(page_w), float(page_h))
    unit = config.plotter_unit_length * MM_PER_PX
    ox, oy = (v * MM_PER_PX for v in pc.origin_location)
    if pc.origin_location_reference == "botleft":
        oy = paper_h - oy
    turned = (page_w > page_h) != (paper_w > paper_h)
    corners = []
    for u, v in ((pc.x_range[0], pc.y_range[0]), (pc.x_range[1], pc.y_range[1])):
        x, y = ox + u * unit, (oy - v * unit) if pc.y_axis_up else (oy + v * unit)
        if pc.rotate_180:
            x, y = paper_w - x, paper_h - y
        corners.append((paper_h - y, x) if turned else (x, y))   # vpype turns the page by -90 deg
    (xa, ya), (xb, yb) = corners
    return (max(0.0, min(xa, xb)), max(0.0, min(ya, yb)),
            min(float(page_w), max(xa, xb)), min(float(page_h), max(ya, yb)))
