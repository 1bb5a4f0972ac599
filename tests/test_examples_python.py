"""The Python examples run with the public API only."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.usefixtures("numba_one_thread")
def test_lammps_hopper_example_discharges(tmp_path: Path) -> None:
    spec = importlib.util.spec_from_file_location("lammps_hopper", EXAMPLES / "lammps_hopper.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    sim = module.main(steps=1500, out=tmp_path)
    st = sim.state
    assert st.n > 500
    # the walls hold the column: nothing crossed the cone's surface
    z, rho = st.x[:, 2], np.hypot(st.x[:, 0], st.x[:, 1])
    inside_cone = rho <= 1.5 + (6.0 - 1.5) * np.clip(z, 0, 8) / 8.0 + 1e-9
    assert np.all(inside_cone | (z < 0.5))
    rows = (tmp_path / "thermo.csv").read_text().splitlines()
    assert [int(r.split(",")[0]) for r in rows[1:]] == [0, 500, 1000, 1500]


@pytest.mark.usefixtures("numba_one_thread")
def test_coarse_grain_example_maps_a_hopper_run(tmp_path: Path) -> None:
    """examples/coarse_grain_hopper.py: a run with frames and contacts, read back and
    coarse-grained (maps and a centre-line profile with block errors), figures written."""
    spec = importlib.util.spec_from_file_location("cg_hopper", EXAMPLES / "coarse_grain_hopper.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    maps, profile = module.main(tmp_path, steps=1500)
    for name in ("packing_fraction", "velocity_y", "pressure", "centre_line"):
        assert (tmp_path / f"{name}.png").stat().st_size > 10_000
    phi = maps.packing_fraction
    assert 0.3 < np.nanmax(phi) < 1.0  # a dense pile somewhere, never over-full
    assert np.nanmax(maps.pressure) > 0
    assert profile.blocks == 4 and np.isfinite(profile.errors("pressure")).any()
