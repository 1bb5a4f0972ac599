"""The example gallery: parse, run and render ``examples/gallery/plot_*.py``.

The scripts are in sphinx-gallery's format: the module docstring is the page's Markdown
(its first line ``# Title``), and the rest is cut into cells by ``# %%`` lines; the comment
lines right after a ``# %%`` are the cell's Markdown text, the code after them its code.

Our plotting functions render with matplotlib's Agg canvas, without pyplot, and write image
files; so a script writes its figures (PNG, SVG, JPEG, a GIF or an MP4 movie) into the
current working directory, and the page shows every image a cell wrote (new or changed
files) right after that cell.

Each script runs in a subprocess (this file run as ``python gallery.py SCRIPT RESULT``) in
a fresh temporary directory, never in the source tree; the cells run one after the other in
one namespace, and the driver records each cell's printed output, the images it wrote and
its time into ``RESULT`` (JSON) after every cell. The whole script gets ``limit`` seconds
(600 by default, a guard against a hung script: the two-minute budget of a gallery script is
measured and shown on its page, not enforced, since timing depends on the machine and on
whether numba's cache is warm): a script that runs longer is killed, and one that fails raises
:class:`GalleryError` naming the script, the cell's line and the traceback.

This module does not import mkdocs: ``docs/_hooks/grainflow_docs.py`` turns its pages into
site files, and ``tests/test_docs_site.py`` exercises it directly.
"""

from __future__ import annotations

import ast
import contextlib
import io
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path

#: Files a cell may write that the page shows (the rest are ignored).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".gif", ".svg", ".webp")
MOVIE_SUFFIXES = (".mp4", ".webm")
SHOWN_SUFFIXES = IMAGE_SUFFIXES + MOVIE_SUFFIXES
#: The default wall-time limit of one script (seconds).
DEFAULT_LIMIT = 600.0
#: A cell separator: ``# %%`` (optionally with text after it) or a line of 20+ ``#``.
_SEPARATOR = re.compile(r"^(# ?%%.*|#{20,})\s*$")


class GalleryError(RuntimeError):
    """A gallery script that does not follow the convention, fails, or runs too long."""


@dataclass
class Block:
    """One part of a script: ``kind`` is ``"text"`` (Markdown) or ``"code"``; ``line`` is
    the line of the script it starts on (1-based)."""

    kind: str
    content: str
    line: int


@dataclass
class Script:
    """A parsed gallery script."""

    path: Path
    title: str
    docstring: str
    blocks: list[Block]

    @property
    def name(self) -> str:
        return self.path.stem

    @property
    def code_blocks(self) -> list[Block]:
        return [b for b in self.blocks if b.kind == "code"]


@dataclass
class Cell:
    """What one code cell did when it ran."""

    stdout: str = ""
    images: list[str] = field(default_factory=list)
    seconds: float = 0.0
    error: str | None = None


@dataclass
class Result:
    """A script's run: its cells (one per code block), the files they showed (name ->
    bytes) and the wall time of the whole subprocess; ``executed`` False when the gallery
    was built without running the scripts."""

    script: Script
    executed: bool
    seconds: float = 0.0
    cells: list[Cell] = field(default_factory=list)
    files: dict[str, bytes] = field(default_factory=dict)

    @property
    def thumbnail(self) -> str | None:
        """The first image (not a movie) the script wrote."""
        for cell in self.cells:
            for name in cell.images:
                if name.lower().endswith(IMAGE_SUFFIXES):
                    return name
        return None


# ------------------------------------------------------------------------------- parsing
def parse(path: str | Path) -> Script:
    """Read a gallery script; GalleryError if it does not follow the convention (a module
    docstring whose first line is a ``# Title``, valid Python)."""
    path = Path(path)
    source = path.read_text(encoding="utf-8")
    try:
        tree = ast.parse(source, filename=str(path))
    except SyntaxError as err:
        raise GalleryError(f"{path.name}: not valid Python (line {err.lineno}: {err.msg})") from None
    first = tree.body[0] if tree.body else None
    docstring = ast.get_docstring(tree, clean=True)
    if first is None or docstring is None:
        raise GalleryError(f"{path.name}: no module docstring; a gallery script starts with a "
                           '"""# Title\\n\\ntext ...""" docstring (Markdown)')
    title_line = docstring.splitlines()[0].strip()
    if not title_line.startswith("# ") or not title_line[2:].strip():
        raise GalleryError(f"{path.name}: the docstring's first line is {title_line!r}; expected "
                           "a Markdown title '# Title'")
    lines = source.splitlines()
    blocks = _blocks(lines, first.end_lineno or 1)
    if not any(b.kind == "code" for b in blocks):
        raise GalleryError(f"{path.name}: no code after the docstring")
    return Script(path, title_line[2:].strip(), docstring, blocks)


def _blocks(lines: list[str], after: int) -> list[Block]:
    """Text and code blocks of the lines after line ``after`` (1-based; the docstring)."""
    blocks: list[Block] = []
    k = after
    code: list[str] = []
    code_start = k + 1

    def flush_code() -> None:
        text = "\n".join(code).strip("\n")
        if text.strip():
            lead = next(i for i, line in enumerate(code) if line.strip())
            blocks.append(Block("code", text.rstrip(), code_start + lead))

    while k < len(lines):
        line = lines[k]
        if _SEPARATOR.match(line):
            flush_code()
            text, start = [], k + 1
            head = line.strip().lstrip("#").strip()
            head = head[2:].strip() if head.startswith("%%") else ""
            if head:
                text.append(f"## {head}")
            k += 1
            while k < len(lines) and lines[k].startswith("#") and not _SEPARATOR.match(lines[k]):
                text.append(re.sub(r"^# ?", "", lines[k]))
                k += 1
            if any(t.strip() for t in text):
                blocks.append(Block("text", "\n".join(text).strip("\n"), start))
            code, code_start = [], k + 1
            continue
        code.append(line)
        k += 1
    flush_code()
    return blocks


def scripts(folder: str | Path, pattern: str = "plot_*.py") -> list[Path]:
    """The gallery scripts of ``folder``, sorted by name."""
    return sorted(Path(folder).glob(pattern))


# ------------------------------------------------------------------------------- running
def run(script: Script, limit: float = DEFAULT_LIMIT, python: str = sys.executable) -> Result:
    """Run ``script`` in a fresh temporary directory (removed afterwards) in a subprocess;
    GalleryError naming the script if it fails or runs longer than ``limit`` seconds."""
    workdir = Path(tempfile.mkdtemp(prefix=f"grainflow-gallery-{script.name}-"))
    result_file = workdir.parent / f"{workdir.name}.json"
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONUNBUFFERED": "1"}
    start = time.perf_counter()
    try:
        proc = subprocess.Popen([python, str(Path(__file__).resolve()), str(script.path.resolve()),
                                 str(result_file)], cwd=workdir, env=env,
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                stdin=subprocess.DEVNULL, start_new_session=True)
        try:
            log, _ = proc.communicate(timeout=limit)
        except subprocess.TimeoutExpired:
            _kill(proc)
            done = _read_cells(result_file)
            where = (f" (it had finished {len(done)} of {len(script.code_blocks)} cells; the "
                     f"next starts at line {script.code_blocks[len(done)].line})"
                     if len(done) < len(script.code_blocks) else "")
            raise GalleryError(f"{script.path.name}: still running after {limit:g} s, the "
                               f"gallery's limit per script{where}; make it shorter") from None
        seconds = time.perf_counter() - start
        cells = _read_cells(result_file)
        tail = log.decode("utf-8", "replace")[-3000:]
        failed = next((k for k, c in enumerate(cells) if c.error), None)
        if failed is not None:
            line = script.code_blocks[failed].line
            raise GalleryError(f"{script.path.name}: the cell at line {line} failed:\n"
                               f"{cells[failed].error}")
        if proc.returncode != 0 or len(cells) != len(script.code_blocks):
            raise GalleryError(f"{script.path.name}: the script's process ended with exit "
                               f"status {proc.returncode} after {len(cells)} of "
                               f"{len(script.code_blocks)} cells; its output ends:\n{tail}")
        files = {name: (workdir / name).read_bytes() for cell in cells for name in cell.images}
        return Result(script, True, seconds, cells, files)
    finally:
        shutil.rmtree(workdir, ignore_errors=True)
        result_file.unlink(missing_ok=True)


def not_run(script: Script) -> Result:
    """The result of a script shown without running it."""
    return Result(script, False, 0.0, [Cell() for _ in script.code_blocks], {})


def _kill(proc: subprocess.Popen) -> None:
    """Kill the script's process group (the script and whatever it started)."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        proc.kill()
    proc.communicate()


def _read_cells(path: Path) -> list[Cell]:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return []
    return [Cell(**c) for c in data]


# ----------------------------------------------------------------------------- rendering
def page(result: Result, images_dir: str, download: str, html_dir: str | None = None) -> str:
    """The Markdown page of a script; images are linked as ``images_dir/NAME`` and the
    script itself as ``download`` (both relative to the page's source file). Movies are raw
    HTML, whose links MkDocs does not rewrite: ``html_dir`` is the images folder relative to
    the page's URL (default ``images_dir``)."""
    script = result.script
    out = [script.docstring.strip(), ""]
    if result.executed:
        out.append(f"!!! info \"Ran in {result.seconds:.1f} s when this site was built\"\n"
                   f"    [Download the script]({download}) (`{script.path.name}`) and run it: "
                   "`python3 " + script.path.name + "` writes the figures below into the "
                   "current directory.")
    else:
        out.append("!!! note \"Not run in this build\"\n"
                   "    This site was built with `GRAINFLOW_DOCS_GALLERY=0`: the script is "
                   f"shown without its output. [Download the script]({download}) "
                   f"(`{script.path.name}`) and run it with `python3 {script.path.name}`.")
    out.append("")
    code_index = 0
    for block in script.blocks:
        if block.kind == "text":
            out += [block.content, ""]
            continue
        cell = result.cells[code_index]
        code_index += 1
        out += [_fence(block.content, "python"), ""]
        if cell.stdout.strip():
            out += [_fence(cell.stdout.rstrip("\n"), "text", title="Output"), ""]
        for name in cell.images:
            if name.lower().endswith(MOVIE_SUFFIXES):
                url = f"{images_dir if html_dir is None else html_dir}/{name}"
                out += [f'<video controls loop muted playsinline width="100%" src="{url}">'
                        f'<a href="{url}">{name}</a></video>', ""]
            else:
                out += [f"![{name}]({images_dir}/{name})", ""]
    return "\n".join(out).rstrip() + "\n"


def index_page(results: list[Result], link: dict[str, str], images: dict[str, str]) -> str:
    """The gallery's front page: one card per script (title, first image, time).
    ``link``/``images``: script name -> its page / its images folder, relative to the
    index."""
    out = ["# Gallery", "",
           "Each example is a script in `examples/gallery/`, in sphinx-gallery's format "
           "(a Markdown docstring, then cells separated by `# %%` comments). They are run "
           "when this site is built, each in a fresh temporary directory (each is meant to "
           "take under two minutes on two cores: the table below gives the times of this "
           "build; on a fresh clone the first run also compiles numba's kernels, up to "
           "about two minutes more per script, which the cache in the checkout then saves), "
           "and every figure or movie a cell writes "
           "into its working directory is shown after that cell. "
           "`GRAINFLOW_DOCS_GALLERY=0 python3 -m mkdocs build` shows the scripts without "
           "running them.", ""]
    if not results:
        return "\n".join(out + ["No example yet.", ""])
    out += ['<div class="grid cards" markdown>', ""]
    for r in results:
        name = r.script.name
        item = [f"-   **[{r.script.title}]({link[name]})**", ""]
        thumb = r.thumbnail
        if thumb is not None:
            item += [f"    [![{r.script.title}]({images[name]}/{thumb})]({link[name]})", ""]
        when = f"{r.seconds:.1f} s" if r.executed else "not run in this build"
        item += [f"    `{r.script.path.name}`: {when}", ""]
        out += item
    out += ["</div>", ""]
    if any(r.executed for r in results):
        out += ["| script | wall time (s) |", "|---|---|"]
        out += [f"| [`{r.script.path.name}`]({link[r.script.name]}) | {r.seconds:.1f} |"
                for r in results if r.executed]
        out.append("")
    return "\n".join(out)


def _fence(text: str, lang: str, title: str | None = None) -> str:
    ticks = "```"
    while ticks in text:
        ticks += "`"
    head = f'{ticks}{lang}' + (f' title="{title}"' if title else "")
    return f"{head}\n{text}\n{ticks}"


# ------------------------------------------------------------------------ the subprocess
def _snapshot(root: Path) -> dict[str, tuple[int, int]]:
    out = {}
    for p in root.rglob("*"):
        if p.is_file():
            st = p.stat()
            out[p.relative_to(root).as_posix()] = (st.st_mtime_ns, st.st_size)
    return out


def _drive(script_path: str, result_path: str) -> int:
    """Run the cells of a script in this process (its working directory is the script's
    fresh folder); write the cells' results to ``result_path`` after each."""
    script = parse(script_path)
    root = Path.cwd()
    namespace = {"__name__": "__main__", "__file__": str(script.path), "__doc__": script.docstring}
    sys.argv = [str(script.path)]
    sys.path[0] = str(script.path.parent)  # as `python SCRIPT`: not this hooks folder
    cells: list[dict] = []
    for block in script.code_blocks:
        before = _snapshot(root)
        buffer = io.StringIO()
        error = None
        start = time.perf_counter()
        code = compile("\n" * (block.line - 1) + block.content, str(script.path), "exec")
        with contextlib.redirect_stdout(buffer), contextlib.redirect_stderr(buffer):
            try:
                exec(code, namespace)
            except BaseException:  # noqa: BLE001 (reported, then the run stops)
                error = traceback.format_exc()
        seconds = time.perf_counter() - start
        after = _snapshot(root)
        written = [name for name, stamp in after.items()
                   if before.get(name) != stamp and name.lower().endswith(SHOWN_SUFFIXES)]
        written.sort(key=lambda name: (after[name][0], name))
        cells.append({"stdout": buffer.getvalue(), "images": written, "seconds": seconds,
                      "error": error})
        Path(result_path).write_text(json.dumps(cells))
        if error is not None:
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(_drive(sys.argv[1], sys.argv[2]))
