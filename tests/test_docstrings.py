"""Every public function and class has a numpydoc ``Examples`` section.

Public: the names in ``__all__`` of the package and of every public module
(no leading underscore, ``diskpack_cl.cli`` included), functions and
classes only (constants carry no docstring of their own). The examples
themselves run as doctests: ``pytest`` collects ``diskpack_cl`` with
``--doctest-modules`` (pyproject.toml), and ``conftest.py`` skips those that
need an OpenCL device where there is none.
"""

import importlib
import inspect
import pkgutil

import pytest

import diskpack_cl


def public_modules():
    """``diskpack_cl``, its public modules and the ``cli`` package."""
    names = [m.name for m in pkgutil.iter_modules(diskpack_cl.__path__) if not m.name.startswith("_")]
    return [diskpack_cl] + [importlib.import_module(f"diskpack_cl.{n}") for n in sorted(names)]


def public_objects():
    """``{qualified name: object}`` of every function and class some public ``__all__`` names."""
    out = {}
    for module in public_modules():
        for name in module.__all__:
            obj = getattr(module, name)
            if inspect.isfunction(obj) or inspect.isclass(obj):
                out.setdefault(f"{obj.__module__}.{obj.__qualname__}", obj)
    return out


def has_examples(obj):
    """Whether the docstring has a numpydoc Examples section with at least one ``>>>`` line."""
    doc = inspect.getdoc(obj) or ""
    if "\nExamples\n--------\n" not in "\n" + doc:
        return False
    return ">>> " in doc.split("Examples\n--------\n", 1)[1]


def test_public_modules_declare_all():
    missing = [m.__name__ for m in public_modules() if not hasattr(m, "__all__")]
    assert not missing, f"public modules without __all__ (their public API is unstated): {missing}"


def test_public_objects_are_found():
    objects = public_objects()
    assert len(objects) > 150
    for name in ("diskpack_cl.stipple.stipple", "diskpack_cl.poisson.poisson_disk",
                 "diskpack_cl.cli.build_parser", "diskpack_cl.device.context.get_context"):
        assert name in objects


def test_every_public_object_has_an_examples_section():
    missing = sorted(name for name, obj in public_objects().items() if not has_examples(obj))
    assert not missing, f"{len(missing)} public objects without an Examples section: {missing}"


@pytest.mark.parametrize("doc, want", [
    ("Summary.\n\nExamples\n--------\n>>> 1 + 1\n2\n", True),
    ("Summary.\n\nExamples\n--------\nSee the gallery.\n", False),
    ("Summary.\n\n>>> 1 + 1\n2\n", False),
])
def test_has_examples_reads_numpydoc_sections(doc, want):
    def f():
        pass
    f.__doc__ = doc
    assert has_examples(f) is want
