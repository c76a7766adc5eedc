"""The colour module before it was split by subject, kept for one release: each of its
names still imports from here, with a :class:`DeprecationWarning` naming its new home.

The homes: :mod:`diskpack_cl.colorspace` (sRGB, linear light, CIELAB, the area mix),
:mod:`diskpack_cl.pens` (palettes, pen texts, :class:`~diskpack_cl.pens.ColorOptions`),
:mod:`diskpack_cl.palette` (``auto:N``), :mod:`diskpack_cl.separation`,
:mod:`diskpack_cl.image` (``load_rgb``), :mod:`diskpack_cl.pen_radii` and
:mod:`diskpack_cl.color_measures` (``render_pens`` and the measures).
"""

import importlib
import warnings

__all__ = ["MOVED"]

#: Each public name of the old module and the module it lives in now.
MOVED = {name: home for home, names in {
    "colorspace": ["srgb_to_linear", "linear_to_srgb", "srgb_to_lab", "area_mix", "delta_e",
                   "linear_negative", "hex_color"],
    "pens": ["ColorOptions", "PALETTES", "parse_pens", "parse_pen_dots", "parse_auto",
             "check_paper", "palette_of", "AUTO_MAX_PENS", "check_colors", "PEN_SHARE_EXPONENT"],
    "palette": ["auto_palette", "NO_HUE", "has_hue", "grey_note"],
    "separation": ["Separation", "separate"],
    "image": ["load_rgb"],
    "pen_radii": ["pen_tone_radii", "pen_ink_radii"],
    "color_measures": ["render_pens", "pen_spacing", "color_measures", "MIN_DOTS"],
}.items() for name in names}


def __getattr__(name):
    if name not in MOVED:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    warnings.warn(f"diskpack_cl.color.{name} is now diskpack_cl.{MOVED[name]}.{name}; "
                  f"diskpack_cl.color goes in the next release", DeprecationWarning, stacklevel=2)
    return getattr(importlib.import_module(f"diskpack_cl.{MOVED[name]}"), name)
