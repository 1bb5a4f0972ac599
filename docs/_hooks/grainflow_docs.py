"""mkdocs hooks of the grainflow site (``hooks:`` in mkdocs.yml).

Pages generated at build time, in memory (nothing is written into docs/ or examples/):

* ``config_reference.md``: :func:`grainflow.config.reference.reference_markdown`, the
  configuration reference rendered from the pydantic schema;
* ``api/grainflow.md``: the top-level API (``grainflow.__init__``'s lazy public names, which
  static analysis cannot see), with links to where each is documented;
* ``gallery/``: one page per ``examples/gallery/plot_*.py`` (``gallery.py`` beside this file
  parses, runs and renders them), its figures and movies, the script for download, and an
  index. The gallery's nav entries are added to ``nav`` here.

Environment:

* ``GRAINFLOW_DOCS_GALLERY=0`` shows the scripts without running them (quick local builds);
  anything else, or unset, runs every script (what CI does).
* ``GRAINFLOW_DOCS_GALLERY_LIMIT``: wall-time limit per script in seconds (default 600: a
  guard against a hung script; each script's time is shown on its page).

A gallery script that fails, or runs past the limit, stops the build with an error naming it.
Under ``mkdocs serve`` a script's results are kept between rebuilds until its text changes.
"""

from __future__ import annotations

import hashlib
import importlib
import inspect
import logging
import os
import sys
from pathlib import Path
from typing import Any

from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File, Files

sys.path.insert(0, str(Path(__file__).resolve().parent))
import gallery  # noqa: E402  (beside this file)

ROOT = Path(__file__).resolve().parents[2]
GALLERY_SOURCE = ROOT / "examples" / "gallery"
GALLERY_DIR = "gallery"  # in the site
log = logging.getLogger("mkdocs.hooks.grainflow_docs")

#: Modules of the top level documented in full on the top-level API page (the packages have
#: pages of their own).
TOP_LEVEL_MODULES = ("grainflow.state", "grainflow.frame", "grainflow.units",
                     "grainflow.rings", "grainflow.runner")
#: Package -> its API page (to link the top-level names to).
API_PAGES = {
    "grainflow.engine": "engine.md", "grainflow.models": "models.md",
    "grainflow.walls": "walls.md", "grainflow.insertion": "insertion.md",
    "grainflow.scenarios": "scenarios.md", "grainflow.analysis": "analysis.md",
    "grainflow.io": "io.md", "grainflow.config": "config.md",
    "grainflow.plotting": "plotting.md", "grainflow.sweep": "sweep.md",
    "grainflow.studies": "studies.md",
}

_state: dict[str, Any] = {"command": "build", "cache": {}}


def gallery_enabled() -> bool:
    """Whether the gallery scripts run in this build (``GRAINFLOW_DOCS_GALLERY``)."""
    return os.environ.get("GRAINFLOW_DOCS_GALLERY", "1").strip().lower() not in (
        "0", "false", "no", "off")


def gallery_limit() -> float:
    text = os.environ.get("GRAINFLOW_DOCS_GALLERY_LIMIT", "")
    try:
        return float(text) if text else gallery.DEFAULT_LIMIT
    except ValueError:
        raise PluginError(f"GRAINFLOW_DOCS_GALLERY_LIMIT={text!r}: expected seconds") from None


# ----------------------------------------------------------------------------- events
def on_startup(command: str, dirty: bool) -> None:
    _state["command"] = command


def on_config(config: Any) -> Any:
    """Parse the gallery scripts (a malformed one stops the build here) and list their
    pages in the nav, under the ``gallery/index.md`` entry."""
    try:
        scripts = [gallery.parse(p) for p in gallery.scripts(GALLERY_SOURCE)]
    except gallery.GalleryError as err:
        raise PluginError(f"gallery: {err}") from None
    _state["scripts"] = scripts
    entries = [f"{GALLERY_DIR}/index.md"] + [
        {s.title: f"{GALLERY_DIR}/{s.name}.md"} for s in scripts]
    config["nav"] = _replace_in_nav(config["nav"], f"{GALLERY_DIR}/index.md", entries)
    return config


def on_files(files: Files, config: Any) -> Files:
    from grainflow.config.reference import reference_markdown

    files.append(File.generated(config, "config_reference.md", content=reference_markdown()))
    files.append(File.generated(config, "api/grainflow.md", content=top_level_api_page()))
    for f in gallery_files(config):
        files.append(f)
    return files


# --------------------------------------------------------------------------- the gallery
def gallery_files(config: Any) -> list[File]:
    """Run (or not) every script and return the gallery's generated files."""
    run = gallery_enabled()
    limit = gallery_limit()
    results = []
    for script in _state.get("scripts", []):
        results.append(_result(script, run, limit))
    if run and results:
        total = sum(r.seconds for r in results)
        log.info("gallery: %d scripts ran in %.1f s (%s)", len(results), total,
                 ", ".join(f"{r.script.name} {r.seconds:.1f} s" for r in results))
    elif results:
        log.info("gallery: GRAINFLOW_DOCS_GALLERY=0, %d scripts shown without running them",
                 len(results))
    out = []
    for r in results:
        name = r.script.name
        out.append(File.generated(config, f"{GALLERY_DIR}/{name}.md",
                                  content=gallery.page(r, images_dir=name,
                                                       download=f"{name}.py",
                                                       html_dir=html_dir(config, name))))
        out.append(File.generated(config, f"{GALLERY_DIR}/{name}.py",
                                  content=r.script.path.read_bytes()))
        for image, data in r.files.items():
            out.append(File.generated(config, f"{GALLERY_DIR}/{name}/{image}", content=data))
    links = {r.script.name: f"{r.script.name}.md" for r in results}
    images = {r.script.name: r.script.name for r in results}
    out.append(File.generated(config, f"{GALLERY_DIR}/index.md",
                              content=gallery.index_page(results, links, images)))
    return out


def html_dir(config: Any, name: str) -> str:
    """The folder of gallery page ``name``'s images as its URL sees it: with directory URLs
    the page ``gallery/NAME.md`` is served as ``gallery/NAME/``, beside its images."""
    return "." if config.use_directory_urls else name


def _result(script: gallery.Script, run: bool, limit: float) -> gallery.Result:
    if not run:
        return gallery.not_run(script)
    key = (str(script.path), hashlib.sha256(script.path.read_bytes()).hexdigest(), limit)
    cache = _state["cache"]
    if _state["command"] == "serve" and key in cache:
        return cache[key]
    log.info("gallery: running %s (limit %g s)", script.path.name, limit)
    try:
        result = gallery.run(script, limit=limit)
    except gallery.GalleryError as err:
        raise PluginError(f"gallery: {err}") from None
    log.info("gallery: %s ran in %.1f s", script.path.name, result.seconds)
    cache[key] = result
    return result


def _replace_in_nav(nav: Any, target: str, entries: list[Any]) -> Any:
    """``nav`` with the item whose page is ``target`` turned into a section of ``entries``."""
    if isinstance(nav, list):
        return [_replace_in_nav(item, target, entries) for item in nav]
    if isinstance(nav, dict):
        return {title: (entries if value == target else _replace_in_nav(value, target, entries))
                for title, value in nav.items()}
    return entries if nav == target else nav


# ----------------------------------------------------------------------- top-level API
def top_level_api_page() -> str:
    """The ``grainflow`` page: every public name of ``import grainflow as gf`` with its
    first docstring line and a link to its documentation, then the top-level modules."""
    import grainflow

    out = ["# `grainflow`: the top-level API", "",
           "`import grainflow as gf` gives these names (imported on first use, so `import "
           "grainflow` stays fast); each links to its documentation. The subpackages "
           + ", ".join(f"[`gf.{p}`]({API_PAGES['grainflow.' + p]})" for p in grainflow._SUBPACKAGES)
           + " are reachable as attributes.", "",
           "| name | what | defined in |", "|---|---|---|"]
    for name, module in grainflow._EXPORTS.items():
        obj = getattr(importlib.import_module(module), name)
        first = (inspect.getdoc(obj) or "").strip().split("\n\n")[0].replace("\n", " ")
        first = first.replace("|", "\\|")
        out.append(f"| [`gf.{name}`][{module}.{name}] | {first} | `{module}` |")
    out.append("")
    for module in TOP_LEVEL_MODULES:
        out += [f"::: {module}", "    options:", "      show_root_heading: true",
                "      heading_level: 2", ""]
    return "\n".join(out)
