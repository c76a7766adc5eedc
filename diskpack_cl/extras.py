"""The optional extras of pyproject.toml, and the command that installs one.

The package is not on the Python package index: an extra is installed from
the repository's folder, into the virtual environment the README makes.

Examples
--------
>>> install_command("vpype")
'.venv/bin/pip install ".[vpype]"'
"""

__all__ = ["install_command"]


def install_command(extra):
    """The shell command that installs the optional ``extra`` from a checkout.

    Parameters
    ----------
    extra : str
        A name of ``[project.optional-dependencies]`` (``plot``, ``vpype``, ``dask``, ...).

    Returns
    -------
    str
        The command, to run in the repository's folder.

    Examples
    --------
    >>> install_command("dask")
    '.venv/bin/pip install ".[dask]"'
    """
    return f'.venv/bin/pip install ".[{extra}]"'
