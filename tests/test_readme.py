"""README.md's Python quickstart runs as printed: the grains fall onto the floor and touch."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def test_quickstart_runs() -> None:
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
    assert blocks, "README.md has no python block"
    namespace: dict = {}
    with contextlib.redirect_stdout(io.StringIO()):
        exec(compile(blocks[0], str(README), "exec"), namespace)
    sim = namespace["sim"]
    assert sim.step == 20_000
    # 405 grains of radius 0.5 from z <= 5.5 land on the plane z = 0 within t = 4
    assert sim.state.x[:, 2].max() < 5.0
    assert sim.contacts().i.size > 100
