"""The documentation site (mkdocs.yml, docs/, docs/_hooks/): the configuration reference
renders every table and field of the schema; every page is in the navigation; the README
sections the site includes are marked; the gallery scripts follow the convention and the
gallery machinery shows what each cell writes, fails on a failing or too slow script, and
writes nothing into the source tree.

The whole site build (about 25 s with the gallery skipped, minutes with it) and the run of
every gallery script are validations (``-m validation``).
"""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
import textwrap
from pathlib import Path
from types import ModuleType
from typing import Any, get_args, get_origin

import pytest
from pydantic import BaseModel

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
HOOKS = DOCS / "_hooks"
GALLERY = ROOT / "examples" / "gallery"

#: Pages the hook generates at build time (not files in docs/).
GENERATED = {"config_reference.md", "api/grainflow.md", "gallery/index.md"}
#: Folders of docs/ that hold no pages of the site.
NOT_PAGES = ("_hooks/",)


def _load(name: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(f"_docs_{name}", HOOKS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


gallery = _load("gallery")


# ------------------------------------------------------------------ configuration reference
def _models_reachable(model: type[BaseModel], seen: set[type[BaseModel]]) -> None:
    if model in seen:
        return
    seen.add(model)
    for info in model.model_fields.values():
        for tp in _types_in(info.annotation):
            if isinstance(tp, type) and issubclass(tp, BaseModel):
                _models_reachable(tp, seen)


def _types_in(tp: Any) -> list[Any]:
    out = [tp]
    for arg in get_args(tp):
        out += _types_in(arg)
    return out


def _section(page: str, anchor: str) -> str:
    """The Markdown from the heading with ``{#anchor}`` to the next heading."""
    match = re.search(rf"^#+ .*\{{#{re.escape(anchor)}\}}\n(.*?)(?=^#{{1,3}} |\Z)", page,
                      re.S | re.M)
    assert match, f"no heading {{#{anchor}}}"
    return match.group(1)


def test_the_reference_has_every_table_and_field_of_the_schema() -> None:
    from grainflow.config.reference import reference_markdown, tables
    from grainflow.config.schema import RunConfig
    from grainflow.scenarios import SCENARIOS, get_scenario

    page = reference_markdown()
    documented = {t.model: t for t in tables()}
    reachable: set[type[BaseModel]] = set()
    _models_reachable(RunConfig, reachable)
    get_scenario("generic")
    for sc in SCENARIOS.values():
        if sc.section is not None:
            _models_reachable(sc.section_model(), reachable)
    missing = {m.__name__ for m in reachable} - {m.__name__ for m in documented}
    assert not missing, f"tables of the schema missing from the reference: {missing}"
    for model, table in documented.items():
        body = _section(page, table.anchor)
        own = [f.name for f in table.fields]
        assert own, table.anchor
        for name in own:
            assert re.search(rf"^\| `{re.escape(name)}` \|", body, re.M), (table.anchor, name)
        if table.extra:  # [contact]: the registry's parameters
            for name in model.model_fields:
                assert f"`{name}`" in page, name
        for row in table.fields:
            assert row.type and row.unit and row.default, (table.anchor, row)


def test_the_reference_gives_types_units_and_defaults() -> None:
    from grainflow.config.reference import tables

    rows = {(t.anchor, f.name): f for t in tables() for f in t.fields}
    dt = rows[("run", "dt")]
    assert (dt.type, dt.unit, dt.default) == ("time > 0", "s", "none")
    assert rows[("run", "dt_fraction")].type == "number > 0, ≤ 0.25"
    assert rows[("run", "dt_fraction")].default == "`0.02`"
    assert (rows[("box", "lo")].type, rows[("box", "lo")].unit) == ("`dim` lengths", "m")
    assert rows[("box", "lo")].default == "required"
    assert rows[("run", "integrator")].type == '`"verlet"` or `"adams_bashforth2"`'
    assert rows[("top-level", "gravity")].unit == "m/s²"
    assert rows[("particles-lattice", "radius")].type == "length > 0, or a list of them"
    assert rows[("scenario-stream", "grain_diameter")].unit == "m"
    assert rows[("scenario-stream", "grain_diameter")].default == "`0.0002`"
    assert rows[("scenario-hopper", "lam")].default == "`inf`"
    assert "(#regions)" in rows[("particles-random", "region")].type
    assert rows[("run", "steps")].description == "number of time steps (or give duration)"


# --------------------------------------------------------------------------- the pages
class _Loader:
    """mkdocs.yml read with PyYAML, its ``!relative`` and ``!!python/name`` tags as text."""

    @staticmethod
    def load(path: Path) -> dict[str, Any]:
        yaml = pytest.importorskip("yaml")

        class Loader(yaml.SafeLoader):
            pass

        Loader.add_multi_constructor("!", lambda loader, suffix, node: str(node.value))
        Loader.add_multi_constructor("tag:yaml.org,2002:python/",
                                     lambda loader, suffix, node: str(node.value))
        return yaml.load(path.read_text(), Loader=Loader)


def _nav_pages(nav: Any) -> list[str]:
    if isinstance(nav, list):
        return [p for item in nav for p in _nav_pages(item)]
    if isinstance(nav, dict):
        return [p for value in nav.values() for p in _nav_pages(value)]
    return [nav] if isinstance(nav, str) and nav.endswith(".md") else []


def test_every_page_is_in_the_navigation_and_every_entry_exists() -> None:
    config = _Loader.load(ROOT / "mkdocs.yml")
    nav = _nav_pages(config["nav"])
    files = {p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md")
             if not p.relative_to(DOCS).as_posix().startswith(NOT_PAGES)}
    assert files - set(nav) == set(), "pages of docs/ missing from mkdocs.yml's nav"
    assert set(nav) - files - GENERATED == set(), "nav entries without a page"
    assert len(nav) == len(set(nav)), "a page is twice in the nav"
    excluded = config.get("exclude_docs", "")
    assert all(folder in excluded for folder in NOT_PAGES)


def test_the_included_readme_sections_are_marked() -> None:
    readme = (ROOT / "README.md").read_text()
    used = set()
    for page in DOCS.rglob("*.md"):
        used |= set(re.findall(r'--8<-- "README\.md:(\w+)"', page.read_text()))
    assert used >= {"intro", "quickstart", "architecture", "setup"}
    for name in used:
        assert readme.count(f"<!-- --8<-- [start:{name}] -->") == 1, name
        assert readme.count(f"<!-- --8<-- [end:{name}] -->") == 1, name


def test_the_strict_build_and_the_link_check_are_configured() -> None:
    config = _Loader.load(ROOT / "mkdocs.yml")
    assert config["strict"] is True
    links = config["validation"]["links"]
    assert {links[k] for k in ("not_found", "anchors", "unrecognized_links",
                               "absolute_links")} == {"warn"}
    assert config["validation"]["nav"]["omitted_files"] == "warn"


def test_external_links_are_well_formed() -> None:
    """External links are not fetched (CI has no web access); they must at least be
    absolute http(s) URLs with a host."""
    from urllib.parse import urlsplit

    pages = [*DOCS.rglob("*.md"), ROOT / "README.md", ROOT / "BENCHMARKS.md"]
    for page in pages:
        for url in re.findall(r"\]\((https?:[^)\s]*)\)", page.read_text()):
            parts = urlsplit(url)
            assert parts.scheme in ("http", "https") and "." in parts.netloc, (page, url)


# ------------------------------------------------------------------------------ gallery
def _scripts() -> list[Path]:
    return gallery.scripts(GALLERY)


def test_there_are_gallery_scripts() -> None:
    assert any(p.name == "plot_free_fall.py" for p in _scripts())


@pytest.mark.parametrize("path", _scripts(), ids=lambda p: p.name)
def test_every_gallery_script_follows_the_convention(path: Path) -> None:
    """A ``# Title`` docstring in Markdown, cells that compile, figures written as files
    (no pyplot window)."""
    script = gallery.parse(path)
    assert script.title and script.code_blocks
    compile(path.read_text(), str(path), "exec")
    source = path.read_text()
    assert "plt.show(" not in source, "the gallery shows image files; write them, do not show"


def test_the_parser_cuts_cells_at_percent_comments(tmp_path: Path) -> None:
    path = tmp_path / "plot_cells.py"
    path.write_text(textwrap.dedent('''\
        """# Cells

        Intro text.
        """

        x = 1

        # %%
        # First heading
        # -------------
        # Some *text*.

        y = x + 1
        # an ordinary comment stays in the code

        # %%
        print(y)
        '''))
    script = gallery.parse(path)
    assert script.title == "Cells"
    kinds = [(b.kind, b.content.splitlines()[0]) for b in script.blocks]
    assert kinds == [("code", "x = 1"), ("text", "First heading"), ("code", "y = x + 1"),
                     ("code", "print(y)")]
    assert script.code_blocks[1].line == 13
    assert "# an ordinary comment" in script.code_blocks[1].content


@pytest.mark.parametrize("doc, message", [
    ("x = 1\n", "no module docstring"),
    ('"""Title without hash"""\nx = 1\n', "expected a Markdown title"),
    ('"""# Title"""\n', "no code"),
    ('"""# Title"""\nx = (\n', "not valid Python"),
])
def test_a_script_off_the_convention_is_refused_by_name(tmp_path: Path, doc: str,
                                                        message: str) -> None:
    path = tmp_path / "plot_bad.py"
    path.write_text(doc)
    with pytest.raises(gallery.GalleryError, match=rf"plot_bad\.py: .*{message}"):
        gallery.parse(path)


def _script(tmp_path: Path, body: str) -> Any:
    folder = tmp_path / "examples"
    folder.mkdir(exist_ok=True)
    path = folder / "plot_demo.py"
    path.write_text(textwrap.dedent(body))
    return gallery.parse(path)


def test_each_cell_shows_the_images_it_wrote_and_nothing_lands_in_the_source(
        tmp_path: Path) -> None:
    script = _script(tmp_path, '''\
        """# Demo

        Writes files.
        """

        from pathlib import Path
        Path("first.png").write_bytes(b"png-1")
        print("one")

        # %%
        # Second
        Path("notes.txt").write_text("not shown")
        Path("movie.mp4").write_bytes(b"mp4")
        Path("anim.gif").write_bytes(b"gif")
        Path("first.png").write_bytes(b"png-2, rewritten")
        ''')
    result = gallery.run(script, limit=60)
    assert [c.images for c in result.cells] == [["first.png"], ["movie.mp4", "anim.gif",
                                                                  "first.png"]]
    assert result.cells[0].stdout == "one\n"
    assert result.files["first.png"] == b"png-2, rewritten"
    assert result.executed and result.seconds > 0
    assert sorted(p.name for p in (tmp_path / "examples").iterdir()) == ["plot_demo.py"]
    page = gallery.page(result, images_dir="plot_demo", download="plot_demo.py")
    assert page.startswith("# Demo")
    assert page.index("![first.png](plot_demo/first.png)") < page.index("Second")
    assert '<video controls' in page and 'src="plot_demo/movie.mp4"' in page
    assert "![anim.gif](plot_demo/anim.gif)" in page
    assert "Ran in" in page and "[Download the script](plot_demo.py)" in page
    # raw HTML is not rewritten by MkDocs: the movie's link is relative to the page's URL
    served = gallery.page(result, images_dir="plot_demo", download="plot_demo.py", html_dir=".")
    assert 'src="./movie.mp4"' in served and "![first.png](plot_demo/first.png)" in served
    index = gallery.index_page([result], {"plot_demo": "plot_demo.md"},
                               {"plot_demo": "plot_demo"})
    assert "[Demo](plot_demo.md)" in index and "plot_demo/first.png" in index


def test_a_failing_script_stops_the_gallery_naming_it(tmp_path: Path) -> None:
    script = _script(tmp_path, '''\
        """# Fails"""

        x = 1

        # %%
        raise RuntimeError("broken on purpose")
        ''')
    with pytest.raises(gallery.GalleryError,
                       match=r"plot_demo\.py: the cell at line 6 failed:(.|\n)*broken on purpose"):
        gallery.run(script, limit=60)


def test_a_script_past_the_limit_is_stopped_naming_it(tmp_path: Path) -> None:
    script = _script(tmp_path, '''\
        """# Slow"""

        import time
        print("started")

        # %%
        time.sleep(60)
        ''')
    with pytest.raises(gallery.GalleryError,
                       match=r"plot_demo\.py: still running after 3 s.*1 of 2 cells.*line 7"):
        gallery.run(script, limit=3)


def test_a_script_shown_without_running() -> None:
    script = gallery.parse(GALLERY / "plot_free_fall.py")
    page = gallery.page(gallery.not_run(script), "plot_free_fall", "plot_free_fall.py")
    assert "Not run in this build" in page and "```python" in page
    assert "free_fall.png" not in page.split("```python")[0]


@pytest.mark.validation
@pytest.mark.parametrize("path", _scripts(), ids=lambda p: p.name)
def test_every_gallery_script_runs_within_the_limit(path: Path) -> None:
    result = gallery.run(gallery.parse(path), limit=gallery.DEFAULT_LIMIT)
    assert result.seconds < gallery.DEFAULT_LIMIT
    assert any(c.images for c in result.cells), "the script shows no figure"


# ----------------------------------------------------------------- docstrings, the build
def test_the_docstring_reading_keeps_parameters_apart_from_prose() -> None:
    normalize = _load("griffe_grainflow").normalize
    doc = textwrap.dedent("""\
        Summary with :func:`~grainflow.io.h5md.read_frames` and :class:`grainflow.frame.Box`.

        Parameters
        ----------
        I, mu : (M,) inertial numbers.
        n : int
            a count.
        path:
            where.

        Prose about the call.
        xlog : a switch.
        Others : as :func:`f`.

        Returns
        -------
        Path
        """)
    out = normalize(doc)
    assert "`read_frames`" in out and "`grainflow.frame.Box`" in out
    head, params = out.split("Parameters\n----------\n")
    assert "Prose about the call." in head and "Other parameters : as `f`." in head
    params = params.split("Returns")[0]
    assert "I, mu\n    (M,) inertial numbers." in params
    assert "n : int\n    a count." in params and "path\n    where." in params
    assert "xlog\n    a switch." in params and "Prose" not in params


def test_the_site_is_found_from_the_package() -> None:
    from grainflow.docs_site import build_command, find_checkout

    root = find_checkout()
    assert root == ROOT
    command = build_command(root, root / "site")
    assert command[1:4] == ["-m", "mkdocs", "build"] and "--strict" in command


@pytest.mark.validation
def test_the_site_builds_strictly_with_the_gallery_skipped(tmp_path: Path) -> None:
    """The build a fresh clone runs, less the gallery's scripts: no warning (--strict: a
    broken link, anchor, snippet or docstring fails it)."""
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocstrings")
    from grainflow.docs_site import build_site

    index = build_site(tmp_path / "site", gallery=False, quiet=True)
    site = index.parent
    assert (site / "config_reference" / "index.html").is_file()
    assert "Configuration reference" in (site / "config_reference" / "index.html").read_text()
    assert (site / "gallery" / "plot_free_fall" / "index.html").is_file()
    assert (site / "api" / "grainflow" / "index.html").is_file()
    assert not list((ROOT / "examples" / "gallery").glob("*.png"))
    out = subprocess.run(["git", "status", "--porcelain", "--", "docs", "examples"], cwd=ROOT,
                         capture_output=True, text=True).stdout
    assert ".png" not in out and "site" not in out
