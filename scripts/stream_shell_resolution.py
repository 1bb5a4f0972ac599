"""How finely the time step must resolve the cohesive shell (docs/streams.md, "The step must
resolve the shell"; the engine's time-step check warns from these numbers).

Measures the capture velocity of two of the stream study's grains by bisection on head-on
collisions (:func:`grainflow.studies.stream_study.measured_capture_velocity`) at the run's
step dt = 0.02 t_c (t_c = 100 us), for shells delta of 100, 50, 20 and 10 nm at the fixed work
of separation F_c delta = 1e-13 J, at two restitutions. Each point starts the contact at
several places within a step (``start_phase``), since at a coarse step where in a step the
pair touches decides how many steps the shell acts. Prints, per point, the shell resolution
u_e dt / delta (u_e = sqrt(2 F_c delta / m_eff), the escape speed: the crossing time's
speed) and v_c dt / delta (the incoming capture velocity), and the mean and the scatter of
the measured capture velocity over the start phases, relative to (2/e) sqrt(F_c delta / m).

Usage (AMD EPYC, one core: about 6 seconds)::

    python scripts/stream_shell_resolution.py [--phases 8] [--iterations 12]
"""

from __future__ import annotations

import argparse

import numpy as np

from grainflow import interrupt
from grainflow.models.cohesion_constant import escape_speed
from grainflow.scenarios.stream import StreamSection, grain_mass
from grainflow.studies.stream_study import measured_capture_velocity

WORK = 1e-13  # F_c delta, J: the full plan's 1000 nN x 100 nm
CONTACT_TIME = "100 us"
DT_FRACTION = 0.02


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--phases", type=int, default=8,
                        help="start phases per point, evenly spread over a step (default 8)")
    parser.add_argument("--iterations", type=int, default=12,
                        help="bisection steps per measurement (default 12: 0.03 %% of v_c)")
    parser.add_argument("--restitutions", type=float, nargs="+", default=[0.88, 0.40])
    parser.add_argument("--shells", type=float, nargs="+", default=[100, 50, 20, 10],
                        help="delta in nm (default 100 50 20 10)")
    args = parser.parse_args()
    phases = (np.arange(args.phases) + 0.5) / args.phases
    section = StreamSection(contact_time=CONTACT_TIME)
    m = grain_mass(section)
    dt = DT_FRACTION * section.contact_time
    print(f"t_c = {CONTACT_TIME}, dt = {1e6 * dt:g} us, F_c delta = {WORK:g} J, "
          f"{args.phases} start phases")
    print("| e | delta (nm) | F_c (nN) | u_e dt / delta | v_c dt / delta | measured / analytic "
          "(mean) | scatter (sd) | range |")
    print("|---|---|---|---|---|---|---|---|")
    for e in args.restitutions:
        for delta_nm in args.shells:
            fc_nN = WORK / (delta_nm * 1e-9) * 1e9
            ratios = []
            for phase in phases:
                measured, analytic = measured_capture_velocity(
                    e, fc_nN, delta_nm, iterations=args.iterations, contact_time=CONTACT_TIME,
                    dt_fraction=DT_FRACTION, start_phase=float(phase))
                ratios.append(measured / analytic)
            r = np.array(ratios)
            u_e = escape_speed(fc_nN * 1e-9, delta_nm * 1e-9, 0.5 * m)
            print(f"| {e:g} | {delta_nm:g} | {fc_nN:g} | {u_e * dt / (delta_nm * 1e-9):.3f} | "
                  f"{u_e / e * dt / (delta_nm * 1e-9):.3f} | {r.mean():.3f} | {r.std():.3f} | "
                  f"{r.min():.3f}-{r.max():.3f} |", flush=True)


if __name__ == "__main__":
    interrupt.run(main)
