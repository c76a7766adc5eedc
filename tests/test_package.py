"""The package's public names load on demand, and the command line starts without the
stippling stack."""

import subprocess
import sys
import types

import diskpack_cl


def _loaded_after(statement):
    code = f"import sys; {statement}; print(' '.join(sorted(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return set(out.stdout.split())


def test_the_command_line_starts_without_the_stippling_stack():
    loaded = _loaded_after("import diskpack_cl.cli")
    assert not loaded & {"scipy.stats", "scipy.ndimage", "diskpack_cl.stipple",
                         "diskpack_cl.qmc", "diskpack_cl.jobs.items", "matplotlib"}


def test_the_command_line_starts_without_reading_installed_metadata():
    # the version comes from diskpack_cl/_version.py, which the build reads too: a lookup of
    # the installed distribution would load importlib.metadata and scan sys.path (30 ms)
    assert "importlib.metadata" not in _loaded_after("import diskpack_cl.cli")


def test_the_version_is_the_installed_distributions_and_the_commands():
    from importlib.metadata import version

    assert diskpack_cl.__version__ == version("diskpack_cl")
    out = subprocess.run([sys.executable, "-m", "diskpack_cl.cli", "--version"],
                         capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["diskpack", diskpack_cl.__version__]


def test_every_public_name_resolves_to_its_module_object():
    for name in diskpack_cl.__all__:
        value = getattr(diskpack_cl, name)
        assert not isinstance(value, types.ModuleType) and value.__name__ == name, name
    assert set(diskpack_cl.__all__) <= set(dir(diskpack_cl))


def test_a_submodule_does_not_shadow_the_function_it_is_named_after():
    loaded = _loaded_after("import diskpack_cl.jobs.items, diskpack_cl; "
                           "assert callable(diskpack_cl.stipple) and "
                           "diskpack_cl.stipple.__module__ == 'diskpack_cl.stipple'")
    assert "diskpack_cl.stipple" in loaded


def test_a_poisson_run_loads_no_picture_raster_or_masked_arrays(ctx, tmp_path):
    # a whole run on the device (ctx: the exact engine's own route takes np.unique), local
    # steps included (their distinct cells: numpy 2's np.unique loads numpy.ma)
    out = tmp_path / "p.npz"
    loaded = _loaded_after("from diskpack_cl.cli import main; "
                           f"assert main(['poisson', '-n', '3000', '--seed', '1', '-q', '-o', {str(out)!r}]) == 0")
    assert out.exists()
    # what numpy and pyopencl load themselves is theirs (numpy 1.26 loads numpy.ma)
    theirs = _loaded_after("import numpy, pyopencl")
    assert not loaded & ({"diskpack_cl.image", "diskpack_cl.device.raster", "numpy.ma"} - theirs)
