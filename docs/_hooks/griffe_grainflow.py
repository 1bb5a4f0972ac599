"""A griffe extension (mkdocs.yml: mkdocstrings' ``extensions``) that reads grainflow's
docstrings the way they are written before the numpy-style parser sees them.

grainflow's docstrings are numpy-style sections (``Parameters`` over a dashed line) in a
house style that numpy's grammar reads differently; this extension changes only the text
handed to the parser (the source is untouched):

* ``name : what it is`` on one line is numpy's ``name : type``; when the part after the
  colon is prose rather than a type it becomes the description (``name`` alone, the text
  indented below), so it is not shown in the *Type* column; ``name:`` becomes ``name``;
* a paragraph inside a ``Parameters``/``Attributes`` section that is not an entry (prose
  about the whole call, after the entries or between them) would be read as more
  parameters; it is moved to just before the section's heading;
* ``Others : as f`` (the remaining parameters are those of ``f``) is such prose too;
* Sphinx roles (``:func:`~grainflow.x.f```) become code spans (`` `f` ``); Markdown has no
  such roles.
"""

from __future__ import annotations

import re
from typing import Any

from griffe import Extension

_ROLE = re.compile(r":(?:py:)?(?:class|func|meth|data|mod|attr|obj|exc|const|ref):`(~?)([^`]+)`")
_HEADING = re.compile(r"^(\s*)(Parameters|Other Parameters|Attributes|Returns|Yields|Raises|"
                      r"Warns|Notes|Examples|See Also|References|Methods)\s*$")
_NAMED = ("Parameters", "Other Parameters", "Attributes")
#: ``name : rest`` or ``name:`` (several names separated by commas)
_ITEM = re.compile(r"^(?P<names>\*{0,2}[A-Za-z_]\w*(?:\s*,\s*\*{0,2}[A-Za-z_]\w*)*)\s*:"
                   r"(?:\s+(?P<rest>.*))?$")
_BARE = re.compile(r"^\*{0,2}[A-Za-z_]\w*(?:\s*,\s*\*{0,2}[A-Za-z_]\w*)*$")
_TYPE_WORDS = re.compile(r"^[\w.\[\]|, ()'\"-]+$")


def _role(match: re.Match[str]) -> str:
    target = match.group(2)
    if match.group(1):
        target = target.rsplit(".", 1)[-1]
    return f"`{target}`"


def _type_like(text: str) -> bool:
    """Whether the text after ``name :`` reads as a type (``int``, ``float, optional``,
    ``str | None``) rather than a description."""
    words = text.replace(",", " ").split()
    return (bool(text) and _TYPE_WORDS.match(text) is not None and len(words) <= 3
            and not text.endswith(".") and not {"the", "a", "an", "of"} & {w.lower() for w in words})


def normalize(text: str) -> str:
    """The docstring text as the numpy parser should read it (module docstring)."""
    text = _ROLE.sub(_role, text)
    lines = text.split("\n")
    out: list[str] = []
    k = 0
    while k < len(lines):
        head = _HEADING.match(lines[k])
        underlined = (head is not None and k + 1 < len(lines)
                      and re.match(r"^\s*-{3,}\s*$", lines[k + 1]) is not None)
        if not underlined or head.group(2) not in _NAMED:
            out.append(lines[k])
            k += 1
            continue
        indent = head.group(1)
        end = k + 2
        while end < len(lines):
            nxt = _HEADING.match(lines[end])
            if (nxt is not None and end + 1 < len(lines)
                    and re.match(r"^\s*-{3,}\s*$", lines[end + 1])):
                break
            end += 1
        items, prose = _split_section(lines[k + 2:end], indent)
        if prose:
            while out and not out[-1].strip():
                out.pop()
            out += ["", *prose, ""]
        out += [lines[k], lines[k + 1], *items]
        k = end
    return "\n".join(out)


def _split_section(body: list[str], indent: str) -> tuple[list[str], list[str]]:
    """The section's entries (rewritten) and the prose paragraphs found among them."""
    items: list[str] = []
    prose: list[str] = []
    target = items
    previous_blank = False
    for line in body:
        stripped = line[len(indent):] if line.startswith(indent) else line.lstrip()
        if not line.strip():
            target.append(line)
            previous_blank = True
            continue
        if stripped[:1].isspace():  # an indented continuation of the current entry or text
            target.append(line)
            previous_blank = False
            continue
        match = _ITEM.match(stripped)
        names = match.group("names") if match is not None else ""
        if match is not None and names.lower() == "others":
            # "Others : as f" (the remaining parameters are f's): prose, not a parameter
            target = prose
            prose.append(f"{indent}Other parameters{stripped[len(names):]}")
        elif match is not None:
            target = items
            rest = (match.group("rest") or "").strip()
            if rest and not _type_like(rest):
                items += [f"{indent}{names}", f"{indent}    {rest}"]
            else:
                items.append(f"{indent}{names} : {rest}" if rest else f"{indent}{names}")
        elif _BARE.match(stripped) and target is items:  # numpy's "name" over its text
            items.append(line)
        else:
            target = prose
            if prose and prose[-1].strip() and previous_blank:
                prose.append("")
            prose.append(line)
        previous_blank = False
    while items and not items[-1].strip():
        items.pop()
    while prose and not prose[-1].strip():
        prose.pop()
    if items:
        items.append("")
    return items, [p[len(indent):] if p.startswith(indent) else p for p in prose]


class GrainflowDocstrings(Extension):
    """Rewrite every docstring with :func:`normalize` before it is parsed."""

    def on_instance(self, *, obj: Any, **kwargs: Any) -> None:
        docstring = getattr(obj, "docstring", None)
        if docstring is not None and docstring.value:
            docstring.value = normalize(docstring.value)
