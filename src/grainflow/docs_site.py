"""Build the documentation site of a grainflow checkout and open it (``grainflow docs``).

The site is built by MkDocs from ``mkdocs.yml`` at the root of the source checkout (the
pages in ``docs/``, the docstrings, the gallery scripts in ``examples/gallery/``); it needs
the ``docs`` extra (``python3 -m pip install -e '.[docs]'``). The same by hand::

    python3 -m mkdocs build --strict                          # into site/
    GRAINFLOW_DOCS_GALLERY=0 python3 -m mkdocs build --strict  # gallery scripts not run

>>> from grainflow.docs_site import build_site, open_site   # doctest: +SKIP
>>> open_site(build_site(gallery=False))                    # doctest: +SKIP
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import webbrowser
from pathlib import Path

__all__ = ["DocsError", "build_command", "build_site", "find_checkout", "open_site"]


class DocsError(RuntimeError):
    """The site cannot be built here (no checkout, the docs extra missing, a failed build)."""


def find_checkout(start: str | Path | None = None) -> Path:
    """The source checkout holding ``mkdocs.yml``: the one this package is installed from
    (an editable install), else ``start`` (default: the working directory) or a folder
    above it. DocsError if there is none."""
    here = Path(__file__).resolve()
    candidates = [here.parents[2]]  # src/grainflow/docs_site.py -> the checkout
    base = Path(start or Path.cwd()).resolve()
    candidates += [base, *base.parents]
    for folder in candidates:
        if (folder / "mkdocs.yml").is_file() and (folder / "docs").is_dir():
            return folder
    raise DocsError("no grainflow source checkout here (a folder with mkdocs.yml and docs/): "
                    "the site is built from a clone of the repository; run this in it, or "
                    "install grainflow from it with python3 -m pip install -e '.[docs]'")


def build_command(checkout: Path, site_dir: Path, *, strict: bool = True) -> list[str]:
    """The MkDocs command line that builds ``checkout``'s site into ``site_dir``."""
    command = [sys.executable, "-m", "mkdocs", "build", "-f", str(checkout / "mkdocs.yml"),
               "-d", str(site_dir)]
    return command + (["--strict"] if strict else [])


def build_site(site_dir: str | Path | None = None, *, gallery: bool = True,
               strict: bool = True, checkout: str | Path | None = None,
               quiet: bool = False) -> Path:
    """Build the site (default into ``site/`` of the checkout) and return its
    ``index.html``. ``gallery=False`` shows the gallery scripts without running them
    (seconds instead of minutes). DocsError if MkDocs is missing or the build fails (its
    output says why: a broken link, a failing gallery script ...)."""
    root = find_checkout() if checkout is None else Path(checkout).resolve()
    if importlib.util.find_spec("mkdocs") is None or importlib.util.find_spec(
            "mkdocstrings") is None:
        raise DocsError("MkDocs is not installed: python3 -m pip install -e '.[docs]' "
                        f"(in {root})")
    site = Path(site_dir).resolve() if site_dir is not None else root / "site"
    env = {**os.environ, "GRAINFLOW_DOCS_GALLERY": "1" if gallery else "0",
           "NO_MKDOCS_2_WARNING": "1"}
    result = subprocess.run(build_command(root, site, strict=strict), cwd=root, env=env,
                            capture_output=quiet, text=True)
    if result.returncode != 0:
        tail = ("\n" + (result.stderr or "")[-4000:]) if quiet else ""
        raise DocsError(f"the documentation build failed (exit status {result.returncode})"
                        f"{tail}")
    index = site / "index.html"
    if not index.is_file():
        raise DocsError(f"the build wrote no {index}")
    return index


def open_site(index: str | Path) -> bool:
    """Open ``index.html`` in a web browser; False if no browser could be started (the path
    is then for the user to open)."""
    try:
        return webbrowser.open(Path(index).resolve().as_uri())
    except webbrowser.Error:
        return False
