"""A conical hopper discharging, written as a LAMMPS user would write the deck.

Each block names the LAMMPS command it replaces; only the public API (``grainflow`` and
its ``walls``/``insertion`` subpackages) is used. Run it with ``python
examples/lammps_hopper.py [steps]``; it writes ``thermo.csv`` into ``lammps_hopper/``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import grainflow as gf


def main(steps: int = 20_000, out: str | Path = "lammps_hopper") -> gf.Simulation:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    # region box block -8 8 -8 8 -25 30 / create_box 2 box (boundary f f f)
    box = gf.Box(lo=np.array([-8.0, -8.0, -25.0]), hi=np.array([8.0, 8.0, 30.0]),
                 periodic=(False, False, False))
    state = gf.ParticleState(3, box)
    # lattice fcc + create_atoms in a cylinder above the cone (fix pour would rain them in)
    fill = gf.insertion.CylinderRegion((0.0, 0.0), 5.4, lo=8.5, hi=22.0)
    x = gf.insertion.lattice_fill(fill, spacing=1.15, kind="fcc", radius=0.5)
    state.add_particles(x, 0.5, density=1.0)
    # pair_style gran/hooke/history 2e5 NULL 50 NULL 0.5 0 ; pair_coeff * *
    law = gf.ContactLaw(2, normal="hooke", damping="viscous", tangential="history")
    law.set_all(kn=2.0e5, gamma_n=50.0, gamma_t=0.0, mu=0.5)
    # timestep 1e-4 ; neighbor 0.1 bin
    sim = gf.Simulation(state, 1.0e-4, law, skin=0.1)
    # region cone cone z 0 0 1.5 6 0 8 open 1 open 2 ; region tube cylinder z 0 0 6 8 30
    # fix wall/gran/region for each (the forces add; each wall keeps its own history)
    cone = gf.walls.Cone.from_lammps("z", 0.0, 0.0, 1.5, 6.0, 0.0, 8.0)
    tube = gf.walls.Cylinder((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 6.0, axial_range=(8.0, 30.0))
    sim.add_force(gf.WallForce([cone, tube], law, wall_type=1))
    # fix gravity 1.0 vector 0 0 -1
    sim.add_force(gf.Gravity([0.0, 0.0, -1.0]))
    # region sink block INF INF INF INF INF -20 ; delete_atoms every 100 steps
    sim.add_updater(gf.insertion.DeleteRegion(gf.insertion.HalfSpace((0, 0, -20.0), (0, 0, 1))),
                    every=100)
    # thermo_style custom step atoms ke ... ; thermo 500 (step 0 is logged too)
    thermo = gf.ThermoLog(out / "thermo.csv")
    sim.add_observer(thermo, every=500)
    # run N
    sim.run(steps)
    thermo.close()
    return sim


if __name__ == "__main__":
    sim = main(int(sys.argv[1]) if len(sys.argv) > 1 else 20_000)
    print(f"{sim.state.n} grains left after {sim.step} steps (t = {sim.time:g}); "
          "see lammps_hopper/thermo.csv")
