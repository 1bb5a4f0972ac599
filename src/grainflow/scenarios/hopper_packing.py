"""The authors' dense start for seed 003's hopper (``[hopper] initial_packing = "inflated"``).

The authors' public 2D code (docs/hopper_study.md, "Initial state") starts a hopper run from
a random fill at packing fraction phi ~ 0.6, relaxed by FIRE with gravity off and every radius
multiplied by 1.2, after which the radii are restored. At 1.2 r the fill is at the jamming
point (2D, 1600 grains: 0.83 of the hopper's area, about four contacts a grain), so FIRE
spreads the grains evenly until no two overlap; restored to their own size no two lie closer
than 0.2 sigma_ij, and the pile is dense (0.58) and touches nothing. Gravity closes the gaps
at once: the pile starts dense instead of falling through the loose fill of random sequential
addition (packing 0.45 at most in 2D), whose impact compresses soft pairs past twice the small
radius in tall piles (N = 3200 stops on the overlap check 12-15 t0 into the run).

The packing is made in a throw-away simulation of its own (the region's walls, a lid over the
orifice and a cap at the top, the harmonic law without friction, no gravity or drag), so the
run's simulation never holds the inflated radii: only the positions come back.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from grainflow.engine.minimize import minimize_fire
from grainflow.user_warnings import warn_user

__all__ = ["AUTHORS_INFLATE", "inflated_packing", "uniform_positions"]

#: The authors' radius factor during their initial FIRE.
AUTHORS_INFLATE = 1.2

#: FIRE stops when no force component on a grain exceeds this fraction of the pair
#: energy scale epsilon (a force per sigma): the inflated packing is then at rest to about
#: 1e-3 of a diameter, against the 0.2 sigma_ij the restored radii leave between grains. (At
#: N = 3200 the fill at 1.2 r is jammed and a tolerance of 1e-6 took 25,000 steps.)
FORCE_TOLERANCE = 1e-3
#: FIRE steps at most (2D: about 3,000 are needed for 1600 grains, 4,000 for 3200).
MAX_FIRE_STEPS = 100_000
#: FIRE's largest step in units of the run's (a twentieth of the contact time). The engine's
#: default (up to ten times the run's and a fifth of the oscillation) is stable for a grain
#: on one contact, but here every grain starts pressed on several: at 2, 3200 grains still
#: oscillated with forces of ~10 epsilon after 30,000 steps; at 1 they settle in 3,700.
FIRE_STEP_FACTOR = 1.0


def uniform_positions(region: Any, radii: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Centres drawn independently and uniformly in ``region`` (each at least its radius from
    the region's edge; overlaps allowed): the random start the authors' FIRE relaxes."""
    lo, hi = (np.asarray(b, dtype=float) for b in region.bounds())
    x = np.empty((radii.size, lo.size))
    for r in np.unique(radii):
        todo = np.flatnonzero(radii == r)
        for _ in range(1000):
            trial = rng.uniform(lo, hi, size=(todo.size, lo.size))
            inside = region.contains(trial, margin=float(r))
            x[todo[inside]] = trial[inside]
            todo = todo[~inside]
            if todo.size == 0:
                break
        else:
            raise ValueError("region: too small for the grains' radii (no position found "
                             "in 1000 draws); enlarge it or lower hopper.fill_fraction")
    return x


def inflated_packing(x: np.ndarray, radii: np.ndarray, types: np.ndarray,
                     walls: Sequence[Any], epsilon: float, inflate: float,
                     *, dim: int, box: Any) -> np.ndarray:
    """Relax centres ``x`` of grains with ``radii`` (types 0/1) inflated by ``inflate`` with
    FIRE, inside ``walls`` (which must close the region: add the lid and the cap), and return
    the relaxed centres (the authors' initialisation, module docstring).

    The law is the soft harmonic pair and wall energy (epsilon/2)(1 - r/sigma)^2 with one
    ``epsilon`` and no friction; FIRE (:func:`~grainflow.engine.minimize.minimize_fire`)
    stops when every force component is below ``FORCE_TOLERANCE * epsilon``, the
    inflated packing's mechanical equilibrium. A FIRE that does not get there in
    ``MAX_FIRE_STEPS`` warns: the start is then less even, and whatever still overlaps at
    the grains' own radii is left to ``run.minimize``.
    """
    from grainflow.engine.simulation import Simulation
    from grainflow.models.soft import SoftLaw
    from grainflow.state import ParticleState
    from grainflow.walls import WallForce

    if not inflate > 1.0:
        raise ValueError(f"hopper.inflate: {inflate!r}; expected a factor above 1 (the "
                         "authors' 1.2)")
    wall_type = 2
    state = ParticleState(dim, box)
    state.add_particles(x, inflate * radii, density=1.0, type=types)
    law = SoftLaw(n_types=3)
    for ti, tj in ((0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2)):
        law.set_pair(ti, tj, epsilon=epsilon, mu_k=0.0)
    # the random start overlaps by up to a diameter (FIRE runs no health check)
    sim = Simulation(state, 1.0, law, max_overlap_fraction=2.0)
    sim.add_force(WallForce(list(walls), law, wall_type))
    sim.dt = sim.stable_time_step(0.05)
    fire = minimize_fire(sim, overlap_tol=float("inf"), force_tol=FORCE_TOLERANCE * epsilon,
                         max_steps=MAX_FIRE_STEPS, dt_max_factor=FIRE_STEP_FACTOR)
    if not fire.converged:
        warn_user(f"hopper: the inflated packing's FIRE stopped after {fire.steps} steps "
                  f"with forces up to {fire.max_force:.3g} (tolerance "
                  f"{FORCE_TOLERANCE * epsilon:.3g}); the start is less even than the "
                  "authors'", RuntimeWarning)
    return state.positions[np.argsort(state.arrays["id"])].copy()

