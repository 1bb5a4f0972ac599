"""Compile a template function with some of its global names bound to chosen objects.

numba calls a function passed as an argument through a pointer; a function bound as a
*global* of the caller is inlined when declared ``inline='always'``, and a global number is a
compile-time constant. The pair loop, the wall loop and the composed contact laws are
written once as templates whose free names (``evaluate``, ``normal_force``, column offsets
...) are bound here, so each law gets its own fully inlined kernel.

Kernels are cached on disk like the other kernels when every source file involved can be
read: the compiled function's name carries a checksum of the template's file, of the bound
names and constants, and of the file of every compiled function the template or a bound
function calls (followed through their globals), so editing a law, a sub-model or a helper
such as the walls' closest-point kernel recompiles the kernels that inline it. (numba's own
cache checks only the file of the function it compiles.)
"""

from __future__ import annotations

import inspect
import types
import zlib
from pathlib import Path
from typing import Any, Callable

import numba
from numba import njit

_CACHE: dict[tuple, Any] = {}


def _source_of(obj: Any) -> bytes | None:
    """The bytes of the file that defines ``obj`` (a numba dispatcher or a function)."""
    fn = getattr(obj, "py_func", obj)
    try:
        return Path(inspect.getfile(fn)).read_bytes()
    except (OSError, TypeError):  # e.g. defined interactively
        return None


def _callees(fn: Any, namespace: dict[str, Any], seen: set[int]) -> list[Any]:
    """Every compiled function that ``fn`` (a Python function) names among ``namespace``,
    and theirs, recursively."""
    out = []
    for name in fn.__code__.co_names:
        obj = namespace.get(name)
        inner = getattr(obj, "py_func", None)
        if inner is None or id(obj) in seen:
            continue
        seen.add(id(obj))
        out.append(obj)
        out += _callees(inner, inner.__globals__, seen)
    return out


def _label(obj: Any) -> str:
    fn = getattr(obj, "py_func", obj)
    if callable(fn) and hasattr(fn, "__qualname__"):
        return f"{fn.__module__}.{fn.__qualname__}"
    return repr(obj)


def specialize(template: Callable, name: str, bindings: dict[str, Any],
               **njit_options: Any) -> Any:
    """``njit(**njit_options)`` of ``template`` with the globals in ``bindings`` replaced.

    ``name`` labels the compiled function (cache files and profiles); the same template,
    name and bindings return the same compiled object.
    """
    key = (template, name, tuple(sorted((k, id(v)) for k, v in bindings.items())),
           tuple(sorted(njit_options.items())))
    compiled = _CACHE.get(key)
    if compiled is not None:
        return compiled
    sources = [_source_of(template)]
    text = [_label(template)]
    for k, v in sorted(bindings.items()):
        if callable(v) or hasattr(v, "py_func"):
            text.append(f"{k}={_label(v)}")
        else:
            text.append(f"{k}={v!r}")
    namespace = {**template.__globals__, **bindings}
    for callee in _callees(template, namespace, set()):
        sources.append(_source_of(callee))
        text.append(_label(callee))
    cacheable = all(s is not None for s in sources)
    digest = zlib.crc32("|".join(text).encode() + b"".join(s or b"" for s in sources))
    full_name = f"{name}_{digest:08x}"
    code = template.__code__.replace(co_name=full_name)
    fn = types.FunctionType(code, {**template.__globals__, **bindings}, full_name)
    fn.__qualname__ = full_name
    fn.__doc__ = template.__doc__
    options = dict(njit_options)
    if options.get("inline") != "always":
        options.setdefault("cache", cacheable)
    compiled = _CACHE[key] = njit(**options)(fn)
    return compiled


def serial(kernel: Any) -> Any:
    """``kernel`` (a ``parallel=True`` numba function) compiled without threads: its
    ``prange`` loops run as plain loops. Called from compiled code with one thread, a
    parallel region costs about 0.5 us more than the plain loop (0.7 against 0.16 us for a
    1,600-element pass), as much as the work of a small system's pass; the step loop of
    :mod:`grainflow.engine.fast_path` uses these twins when it runs on one thread."""
    fn = kernel.py_func
    return specialize(fn, fn.__name__ + "_serial", {}, parallel=False)


def for_threads_now(kernel: Any) -> Any:
    """``kernel`` or, when numba runs one thread, its :func:`serial` twin: what a Python
    call site uses where the compiled step loop calls the twin on one thread, so that a
    one-thread run compiles each kernel once, not twice (a pair kernel with its law inlined
    takes 10-20 s to compile; most of the test suite runs on one thread). The two give
    bitwise the same result (tests/test_fast_path.py)."""
    return serial(kernel) if numba.get_num_threads() == 1 else kernel
