"""Bitwise reproducibility: thread count and checkpoints.

The run is a small 3D pile (frictional, cohesive, polydisperse grains raining onto a frozen
rough base) whose neighbour list is rebuilt and re-sorted many times during the run, so the
history carry, the re-sort and the deterministic force gather are all exercised.

* The same run on 1 and on 2 numba threads gives bitwise identical positions, velocities
  and spins (in subprocesses with ``NUMBA_NUM_THREADS``, and within one process with
  ``numba.set_num_threads``), with the simulation's ``threads`` fixed (not ``"auto"``;
  switching mid-run is tested in test_threads.py).
* A run saved with ``state_dict()`` after k steps, loaded into a freshly built simulation
  and continued, is bitwise identical to the uninterrupted run (velocity Verlet and AB2).
"""

from __future__ import annotations

import copy
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numba
import numpy as np
import pytest

from conftest import build_pile
from grainflow.engine.integrators import AdamsBashforth2, VelocityVerlet

TESTS = Path(__file__).resolve().parent
STEPS = 800


def _snapshot(sim) -> dict[str, np.ndarray]:
    st = sim.state
    order = np.argsort(st.id)
    return {"id": st.id[order], "x": st.x[order], "v": st.v[order],
            "omega": st.omega[order], "force": st.force[order],
            "step": np.array(sim.step), "rebuilds": np.array(sim.rebuilds),
            "generation": np.array(st.generation)}


def _assert_bitwise(a: dict, b: dict) -> None:
    for k in a:
        assert a[k].dtype == b[k].dtype
        assert np.array_equal(a[k], b[k]), f"{k} differs"
        assert a[k].tobytes() == b[k].tobytes(), f"{k} differs in bits"


def _exercised(snap: dict) -> None:
    """The run really rebuilt and re-sorted the list (sort_every = 2)."""
    assert int(snap["rebuilds"]) >= 8
    # every re-sort changes the state's generation (2 insertions + sorts)
    assert int(snap["generation"]) >= 2 + 4


SCRIPT = textwrap.dedent("""
    import sys
    import numpy as np
    import numba
    sys.path.insert(0, {tests!r})
    from conftest import build_pile
    from test_determinism import _snapshot, STEPS
    assert numba.get_num_threads() == {threads}, numba.get_num_threads()
    sim = build_pile()
    sim.threads = {threads}
    sim.run(STEPS)
    np.savez({out!r}, **_snapshot(sim))
""")


def _run_subprocess(threads: int, out: Path) -> dict[str, np.ndarray]:
    env = dict(os.environ)
    env["NUMBA_NUM_THREADS"] = str(threads)
    code = SCRIPT.format(tests=str(TESTS), threads=threads, out=str(out))
    res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-3000:]
    with np.load(out) as f:
        return {k: f[k] for k in f.files}


def test_thread_count_bitwise_subprocesses(tmp_path):
    one = _run_subprocess(1, tmp_path / "one.npz")
    two = _run_subprocess(2, tmp_path / "two.npz")
    _exercised(one)
    _assert_bitwise(one, two)


def test_thread_count_bitwise_in_process():
    before = numba.get_num_threads()
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba was started with a single thread")
    try:
        snaps = []
        for threads in (1, 2):
            numba.set_num_threads(threads)
            sim = build_pile()
            sim.threads = threads  # not "auto": it could run the small pile on one thread
            sim.run(STEPS // 2)
            snaps.append(_snapshot(sim))
    finally:
        numba.set_num_threads(before)
    _assert_bitwise(*snaps)


@pytest.mark.usefixtures("numba_one_thread")
@pytest.mark.parametrize("integrator", [VelocityVerlet, AdamsBashforth2])
@pytest.mark.parametrize("k", [237, 400])
def test_checkpoint_round_trip_bitwise(integrator, k):
    total = STEPS
    ref = build_pile(integrator=integrator())
    ref.run(total)
    ref_snap = _snapshot(ref)
    _exercised(ref_snap)
    # live frictional contacts (tangential springs) and cohesive "touched" flags at the end
    assert np.any(ref.interactions[0].history[:, :3] != 0.0)
    assert np.any(ref.interactions[0].history[:, 3] > 0.0)

    first = build_pile(integrator=integrator())
    first.run(k)
    saved = copy.deepcopy(first.state_dict())
    del first
    resumed = build_pile(integrator=integrator())
    resumed.run(3)  # a fresh simulation that has already done something else
    resumed.load_state_dict(saved)
    assert resumed.step == k
    resumed.run(total - k)
    snap = _snapshot(resumed)
    snap["rebuilds"] = ref_snap["rebuilds"]  # counters of this process, not of the run
    snap["generation"] = ref_snap["generation"]
    _assert_bitwise(ref_snap, snap)
    assert resumed.time == ref.time
    # contact histories identical too
    assert np.array_equal(resumed.neighbors.nbr, ref.neighbors.nbr)
    assert np.array_equal(resumed.interactions[0].history, ref.interactions[0].history)


def test_the_threading_layer_is_chosen_by_the_project() -> None:
    """OpenMP before TBB (numba's default order puts TBB first; issue 11), unless the user
    set a layer in the environment; checked in a fresh process, where no layer is loaded."""
    import subprocess
    import sys

    code = ("import numba, grainflow.engine.simulation as s; print(numba.config."
            "THREADING_LAYER_PRIORITY)")
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_THREADING_LAYER")}
    chosen = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            env=env, check=True).stdout
    assert chosen.strip() == "['omp', 'tbb', 'workqueue']"
    env["NUMBA_THREADING_LAYER_PRIORITY"] = "workqueue omp tbb"
    kept = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env, check=True).stdout
    assert kept.strip() == "['workqueue', 'omp', 'tbb']"
