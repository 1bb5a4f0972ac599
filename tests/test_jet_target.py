"""Seed 002's tethered target (Sano thesis, granular jets): validation against exact solutions.

Units d = 1, m = 1, u0 = 1 throughout. The model (seed 002, Chapter 3 and Table 4.1):

* grain-grain and grain-wall contacts: ``F_n = -k_n delta - eta_n v_n`` with the
  "absolute" dashpot (``m_d = 1``), ``k_t = 0.2 k_n``, ``eta_t = 0.5 eta_n``, Coulomb
  ``mu_p = 0.2``; Table 4.1, e = 0.75: ``k_n = 498``, ``eta_n = 2.88`` (``t_c = 0.10``);
* the target: "one layer of DEM particles with the same diameter d and the same mass m,
  which are connected to each other and with their own initial positions via the spring
  and the dashpot with spring constant k_w = 10.0 m u0^2/d^2 and the dashpot constant
  eta_w = 5.0 eta_n" (:class:`~grainflow.engine.tethers.Tethers`; wall-wall pairs only
  through the springs, i.e. one shared ``body`` id);
* time integration (Appendix B.2, eqs. B.21-B.24): Adams-Bashforth 2 for the velocities,
  ``v_{n+1} = v_n + dt/(2m) (3 F_n - F_{n-1})``, the trapezoid rule for the positions,
  ``x_{n+1} = x_n + dt/2 (v_n + v_{n+1})``, with ``dt = 0.02 t_c``
  (:class:`~grainflow.engine.integrators.AdamsBashforth2`).

While a grain touches one tethered wall particle head-on the four-variable problem
``(z_g, v_g, z_w, v_w)`` is linear (the engine does not clip the attractive end of the
dashpot force, as the seed's linear law does not), and so is the free flight in between, so
the exact solution is a chain of matrix exponentials joined at the touch and separation
times (:class:`ExactHeadOn`). The tests compare the engine with it, check that the energy
and momentum books close along simulated trajectories (also for a bonded 19-particle
patch), and measure AB2's order of convergence.

Why the accuracy is what it is: AB2 + trapezoid is second order for smooth forces. The
contact spring force has only a kink at touch and separation (the local error of the step
across it is O(dt^2) instead of O(dt^3), once per event), so it stays second order; the
contact dashpot force ``eta_n v_n`` *jumps* from 0 to ``eta_n u0`` at first touch (and
back at separation), and any fixed-step scheme that does not locate the event makes an
O(dt) error there, whose size depends on where in a step the event falls. Quantities that
go through a contact with the dashpot on (restitution, contact time, rebound velocity) are
therefore first order in dt; the tethers alone and the dashpot-free contact are second
order (``test_ab2_*``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import brentq

from grainflow.engine.integrators import AdamsBashforth2
from grainflow.engine.simulation import Simulation
from grainflow.engine.tethers import Tethers, neighbor_bonds
from grainflow.frame import Box
from grainflow.models.granular import GranularLaw, restitution_and_contact_time
from grainflow.state import ParticleState

#: one grain or a few gain nothing from threads (see conftest.numba_one_thread)
pytestmark = pytest.mark.usefixtures("numba_one_thread")

# seed 002, Table 4.1 (rows e = 0.75 and e = 0.99): (e, k_n, eta_n); m = d = u0 = 1
TABLE_41_075 = (0.75, 498.0, 2.88)
TABLE_41_099 = (0.99, 493.0, 0.101)
E_N, KN, ETA_N = TABLE_41_075
MU_P = 0.2
KW = 10.0  # k_w = 10 m u0^2 / d^2
U0 = 1.0
#: binary contact time of the e = 0.75 law (m = 1, meff = 1/2): 0.09996
TC = restitution_and_contact_time(KN, ETA_N, 0.5, "absolute")[1]
#: the seed's time step, dt = 0.02 t_c
DT = 0.02 * TC


def eta_w(eta_n: float) -> float:
    """eta_w = 5 eta_n (seed 002, Chapter 3)."""
    return 5.0 * eta_n


def seed_law(kn: float = KN, eta_n: float = ETA_N, mu: float = MU_P) -> GranularLaw:
    """Seed 002's contact law: absolute dashpot, k_t = 0.2 k_n, eta_t = 0.5 eta_n, mu_p."""
    law = GranularLaw()
    law.set_all(kn=kn, gamma_n=eta_n, damping="absolute", kt=0.2 * kn, gamma_t=0.5 * eta_n,
                mu=mu)
    return law


def index_of(st: ParticleState, ids: np.ndarray) -> np.ndarray:
    """Current indices of particle ids (the state may re-sort particles at list builds)."""
    order = np.argsort(st.id)
    return order[np.searchsorted(st.id, np.asarray(ids), sorter=order)]


# ------------------------------------------------------------------ one grain, one tether
def grain_on_tether(dt: float, *, phase: float = 0.37, kn: float = KN, eta_n: float = ETA_N,
                    mu: float = MU_P, eta_wall: float | None = None
                    ) -> tuple[Simulation, Tethers, float]:
    """A grain (d = m = 1) falling at -u0 along z onto one tethered wall particle (d = m = 1,
    ``body=0`` as in the scenario, anchored at the origin), no gravity. The first touch falls
    at ``phase`` of the fifth step. Returns the simulation, its tethers and the initial gap."""
    st = ParticleState(3, Box(np.full(3, -10.0), np.full(3, 10.0), (False,) * 3))
    gap = (4.0 + phase) * dt * U0
    st.add_particles([[0.0, 0.0, 0.0]], 0.5, mass=1.0, body=0)
    st.add_particles([[0.0, 0.0, 1.0 + gap]], 0.5, mass=1.0, v=[[0.0, 0.0, -U0]])
    sim = Simulation(st, dt, seed_law(kn, eta_n, mu), integrator=AdamsBashforth2())
    teth = sim.add_force(Tethers(st.id[:1], KW, eta_w(eta_n) if eta_wall is None else eta_wall))
    return sim, teth, gap


def record_head_on(sim: Simulation, steps: int) -> np.ndarray:
    """Run ``steps`` steps; rows ``(t, z_g, v_g, z_w, v_w)`` at t = 0 and after every step
    (wall = id 0, grain = id 1)."""
    st = sim.state
    rows = []

    def rec(_ctx) -> None:
        w, g = index_of(st, [0, 1])
        rows.append((sim.time, st.x[g, 2], st.v[g, 2], st.x[w, 2], st.v[w, 2]))

    rec(None)
    sim.add_observer(rec)
    sim.run(steps)
    sim.observers.pop()
    return np.array(rows)


def sign_changes(t: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Times where u changes sign, by linear interpolation within the step."""
    k = np.nonzero(np.sign(u[:-1]) != np.sign(u[1:]))[0]
    return t[k] + (t[k + 1] - t[k]) * u[k] / (u[k] - u[k + 1])


class ExactHeadOn:
    """Exact solution of the head-on grain / tethered wall particle problem (m = 1).

    State ``y = (z_g, v_g, z_w, v_w, 1)``; overlap ``delta = 1 - z_g + z_w`` (anchor at 0,
    radii 1/2). In contact (``delta > 0``)::

        v_g' =  k_n delta + eta_n delta'
        v_w' = -k_n delta - eta_n delta' - k_w z_w - eta_w v_w

    and apart the grain flies freely while the wall particle relaxes on its tether. Each
    phase is ``y(t) = expm(A (t - t_k)) y(t_k)``; the phase ends where the overlap changes
    sign, found on a grid of spacing ``h`` and refined with brentq. Any number of contacts
    (the e = 0.99 target rings back into the grain) is followed up to ``t_end``.
    """

    def __init__(self, gap: float, *, kn: float = KN, eta_n: float = ETA_N, kw: float = KW,
                 eta_wall: float | None = None, t_end: float = 5.0, h: float = 2e-4) -> None:
        ew = eta_w(eta_n) if eta_wall is None else eta_wall
        a_free = np.zeros((5, 5))
        a_touch = np.zeros((5, 5))
        for a in (a_free, a_touch):
            a[0, 1] = a[2, 3] = 1.0
        a_touch[1] = [-kn, -eta_n, kn, eta_n, kn]
        a_touch[3] = [kn, eta_n, -kn - kw, -eta_n - ew, -kn]
        a_free[3] = [0.0, 0.0, -kw, -ew, 0.0]
        self.mats = (a_free, a_touch)
        y = np.array([1.0 + gap, -U0, 0.0, 0.0, 1.0])
        t, phase = 0.0, 0
        self.segments = [(t, y, phase)]
        #: [touch, separation] times of every contact
        self.contacts: list[list[float]] = []
        while t < t_end:
            a = self.mats[phase]
            one = expm(a * h)
            inside = 1.0 if phase else -1.0  # sign of the overlap during this phase
            ys, s, end = y, 0.0, None
            while t + s < t_end:
                yn = one @ ys
                if inside * self.overlap(yn) <= 0.0:
                    end = s
                    break
                ys, s = yn, s + h
            if end is None:
                break
            y_start = y
            tau = brentq(lambda q: self.overlap(expm(a * q) @ y_start), end, end + h,
                         xtol=1e-15)
            y = expm(a * tau) @ y_start
            t += tau
            if phase == 0:
                self.contacts.append([t, math.nan])
            else:
                self.contacts[-1][1] = t
            phase = 1 - phase
            self.segments.append((t, y, phase))

    @staticmethod
    def overlap(y: np.ndarray) -> float:
        return 1.0 - y[0] + y[2]

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """(len(t), 4): ``(z_g, v_g, z_w, v_w)`` at the times t."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        starts = np.array([s[0] for s in self.segments])
        out = np.empty((t.size, 4))
        for k, tk in enumerate(t):
            j = max(int(np.searchsorted(starts, tk, side="right")) - 1, 0)
            t0, y0, phase = self.segments[j]
            out[k] = (expm(self.mats[phase] * (tk - t0)) @ y0)[:4]
        return out


def head_on_errors(dt: float, t_end: float, **kw) -> dict:
    """Simulate the head-on impact to ``t_end`` and compare it with :class:`ExactHeadOn`."""
    ekw = {k: kw[k] for k in ("kn", "eta_n", "eta_wall") if k in kw}
    sim, _, gap = grain_on_tether(dt, **kw)
    rec = record_head_on(sim, int(round(t_end / dt)))
    exact = ExactHeadOn(gap, t_end=t_end + dt, **ekw)
    y = exact(rec[:, 0])
    events = sign_changes(rec[:, 0], rec[:, 1] - rec[:, 3] - 1.0)  # surface gap
    first_sep = exact.contacts[0][1]
    after = rec[:, 0] > first_sep + 3 * dt
    return {"rec": rec, "exact": exact, "y": y, "events": events,
            "v_out_sim": rec[np.argmax(after), 2],
            "v_out": exact(first_sep)[0, 1],
            "err": np.abs(rec[:, 1:] - y).max(axis=0)}


def test_head_on_impact_on_tethered_particle_matches_exact_solution():
    """Seed 002 (Table 4.1, e = 0.75) at its own dt = 0.02 t_c: grain rebound velocity,
    contact duration and the wall particle's history ``z_w(t)`` against the exact solution.

    The wall particle is *overdamped*: ``eta_w / 2m = 7.2 > sqrt(k_w / m) = 3.16``, so the
    "ringing" frequency ``omega_d = sqrt(k_w/m - (eta_w/2m)^2)`` is imaginary and the
    particle creeps back to its anchor without overshoot, at the slow rate
    ``s = eta_w/2m - sqrt((eta_w/2m)^2 - k_w/m) = 0.732`` once the fast mode (13.7) has died.
    (With equal masses nearly all the grain's momentum goes into the wall particle, so the
    grain rebounds at only ~0.07 u0, pushed back by the tether through the contact.)
    """
    r = head_on_errors(DT, 5.0)
    rec, exact = r["rec"], r["exact"]
    assert len(exact.contacts) == 1  # one contact; the overdamped tether never comes back
    # measured: |v_out - exact| = 4.5e-4 u0 (exact 0.0704 u0; the O(dt) dashpot error)
    assert 0.06 < r["v_out"] < 0.08
    assert abs(r["v_out_sim"] - r["v_out"]) < 1.2e-3 * U0
    # contact duration (first touch to separation, gap interpolated in the step): exact
    # 0.118646, measured error 6.3e-5
    (t_touch, t_sep), = exact.contacts
    assert len(r["events"]) == 2
    assert r["events"][0] == pytest.approx(t_touch, abs=1e-12)  # free flight is exact
    assert r["events"][1] - r["events"][0] == pytest.approx(t_sep - t_touch, abs=1.5e-4)
    # wall particle's displacement history over 5 (= 3.7 slow relaxation times): largest
    # |z_w| 0.066, measured error 2.7e-5
    assert np.abs(r["y"][:, 2]).max() == pytest.approx(0.066, abs=1e-3)
    assert r["err"][2] < 7e-5
    assert r["err"][3] < 1e-2  # v_w: O(dt) jump error during contact (measured 4.0e-3)

    # overdamped: no ringing frequency; z_w stays below the anchor, then decays at s
    ew = eta_w(ETA_N)
    assert KW - (ew / 2) ** 2 < 0.0
    t, zw = rec[:, 0], rec[:, 3]
    assert np.all(zw[t > t_touch + DT] < 0.0)
    slow = ew / 2 - math.sqrt((ew / 2) ** 2 - KW)
    late = t > 1.5
    rate = -np.polyfit(t[late], np.log(-zw[late]), 1)[0]
    assert rate == pytest.approx(slow, rel=1e-6)  # measured rel. error 2.4e-7


def test_underdamped_target_rings_at_omega_d():
    """Table 4.1's e = 0.99 row (k_n = 493, eta_n = 0.101, so eta_w = 0.505) makes an
    underdamped target: after the impact the wall particle rings at
    ``omega_d = sqrt(k_w/m - (eta_w/2m)^2) = 3.152`` and decays at ``eta_w/2m``. It swings
    back into the almost stopped grain (a second contact at t ~ 1) before the grain leaves.
    Checked against the exact solution at dt = 0.02 t_c."""
    _, kn, eta_n = TABLE_41_099
    tc = restitution_and_contact_time(kn, eta_n, 0.5, "absolute")[1]
    dt = 0.02 * tc
    r = head_on_errors(dt, 6.0, kn=kn, eta_n=eta_n)
    rec, exact = r["rec"], r["exact"]
    assert len(exact.contacts) == 2
    touches = np.ravel(exact.contacts)
    assert r["events"].size == touches.size
    # measured: largest touch / separation time error 6.6e-5
    np.testing.assert_allclose(r["events"], touches, atol=2e-4)
    # z_w: amplitude 0.28, measured error 5.6e-5 over 6 time units (2 contacts, 3 periods)
    assert r["err"][2] < 1.5e-4
    ew = eta_w(eta_n)
    omega_d = math.sqrt(KW - (ew / 2) ** 2)
    t, zw = rec[:, 0], rec[:, 3]
    free = t > touches[-1] + 0.05
    crossings = sign_changes(t[free], zw[free])
    assert crossings.size >= 4  # 5 zero crossings in t = 1.15 ... 6
    period = 2 * np.mean(np.diff(crossings))
    assert 2 * np.pi / period == pytest.approx(omega_d, rel=2e-5)  # measured 6.3e-6
    peaks = np.array([np.abs(zw[(t > a) & (t < b)]).max()
                      for a, b in zip(crossings[:-1], crossings[1:])])
    decay = -np.polyfit(np.arange(peaks.size) * period / 2, np.log(peaks), 1)[0]
    assert decay == pytest.approx(ew / 2, rel=1e-4)  # measured 2.9e-5


# ------------------------------------------------------------------ energy and momentum
def hex_patch(rings: int = 2, spacing: float = 1.0, z: float = -0.5) -> np.ndarray:
    """Triangular-lattice hexagon of 1 + 3 rings (rings + 1) particles in the x-y plane
    (19 for two rings)."""
    pts = [[q * spacing + 0.5 * r * spacing, r * spacing * math.sqrt(3) / 2, z]
           for q in range(-rings, rings + 1) for r in range(-rings, rings + 1)
           if abs(q + r) <= rings]
    return np.array(pts)


def patch_target(dt: float, phase: float = 0.37) -> tuple[Simulation, Tethers]:
    """19 wall particles (one body, each tethered to its anchor, bonded to its six or fewer
    neighbours) hit off-centre, 10 degrees from the normal, by one grain (mu = 0); the first
    touch falls at ``phase`` of the fifth step."""
    st = ParticleState(3, Box(np.full(3, -10.0), np.full(3, 10.0), (False,) * 3))
    wall = hex_patch()
    st.add_particles(wall, 0.5, mass=1.0, body=0)
    th = math.radians(10.0)
    v = np.array([math.sin(th), 0.3 * math.sin(th), -math.cos(th)])
    v *= U0 / np.linalg.norm(v)
    aim = np.array([0.3, 0.2, 0.5])  # a point of the grain centre's path, off-centre
    # back along -v to a gap of (4 + phase) dt: first touch of |aim + v s - x_w| = 1
    d = aim - wall
    b = d @ v
    disc = b * b - (np.einsum("ij,ij->i", d, d) - 1.0)
    s_touch = np.min(-b[disc > 0] - np.sqrt(disc[disc > 0]))
    x = aim + (s_touch - (4.0 + phase) * dt) * v
    st.add_particles([x], 0.5, mass=1.0, v=[v])
    sim = Simulation(st, dt, seed_law(mu=0.0), integrator=AdamsBashforth2())
    ids = st.id[: len(wall)]
    teth = sim.add_force(Tethers(ids, KW, eta_w(ETA_N), bonds=neighbor_bonds(st, ids, 1.05)))
    return sim, teth


class Books:
    """Per-state energy and momentum books of grains + a tethered target (all m = 1,
    head-on or mu = 0 so that tangential forces and spins vanish)."""

    def __init__(self, sim: Simulation, teth: Tethers, eta_n: float) -> None:
        self.sim, self.teth, self.eta_n = sim, teth, eta_n
        self.rows: list[tuple] = []

    def __call__(self, _ctx=None) -> None:
        sim, teth = self.sim, self.teth
        st = sim.state
        ew = teth.eta
        w = index_of(st, teth.ids)
        g = np.nonzero(st.body < 0)[0]
        contact_pe = 0.0
        overlaps, powers = [], []
        for i in g:  # grain - wall particle contacts (no grain-grain pairs here)
            d = st.x[i] - st.x[w]
            r = np.linalg.norm(d, axis=1)
            delta = st.radius[i] + st.radius[w] - r
            vn = np.einsum("ij,ij->i", st.v[i] - st.v[w], d / r[:, None])
            contact_pe += 0.5 * KN * float(np.sum(np.where(delta > 0, delta, 0.0) ** 2))
            overlaps.append(delta)
            powers.append(self.eta_n * vn**2)
        # tethers: anchor dashpots eta_w v^2, bond dashpots eta_w (v_rel . n)^2
        v = st.v[w]
        power_t = ew * float(np.sum(v * v))
        if teth.bond_ids.size:
            i, j = index_of(st, teth.bond_ids[:, 0]), index_of(st, teth.bond_ids[:, 1])
            d = st.x[i] - st.x[j]
            n = d / np.linalg.norm(d, axis=1)[:, None]
            power_t += ew * float(np.sum(np.einsum("ij,ij->i", st.v[i] - st.v[j], n) ** 2))
        anchor_force = (-teth.k * (st.x[w] - teth.anchor) - ew * v).sum(axis=0)
        kinetic = st.kinetic_energy() + st.rotational_energy()
        self.rows.append((sim.time, kinetic, contact_pe, teth.potential_energy(sim.context),
                          power_t, np.concatenate(overlaps), np.concatenate(powers),
                          anchor_force, st.momentum().copy(), float(np.abs(st.omega).max())))

    def run(self, steps: int) -> None:
        self()
        self.sim.add_observer(self)
        self.sim.run(steps)
        self.sim.observers.pop()

    def arrays(self) -> dict:
        """Energies, the dissipation accumulated by the trapezoid rule on the per-step
        dashpot powers, and the trapezoid impulse of the anchor forces."""
        col = list(zip(*self.rows))
        t = np.array(col[0])
        dt = np.diff(t)
        pc = np.where(np.array(col[5]) > 0, np.array(col[6]), 0.0).sum(axis=1)
        pt = np.array(col[4])
        power = pc + pt
        step = 0.5 * dt * (power[:-1] + power[1:])
        dissipated = np.concatenate([[0.0], np.cumsum(step)])
        anchor = np.array(col[7])
        impulse = np.concatenate([np.zeros((1, 3)), np.cumsum(
            0.5 * (anchor[:-1] + anchor[1:]) * dt[:, None], axis=0)])
        kinetic, contact, tether = (np.array(c) for c in col[1:4])
        return {"t": t, "kinetic": kinetic, "contact": contact, "tether": tether,
                "dissipated": dissipated, "total": kinetic + contact + tether + dissipated,
                "anchor": anchor, "impulse": impulse, "momentum": np.array(col[8]),
                "spin": max(col[9])}


def energy_residual(sim: Simulation, teth: Tethers, t_end: float) -> tuple[float, dict]:
    books = Books(sim, teth, ETA_N)
    books.run(int(round(t_end / sim.dt)))
    b = books.arrays()
    return float(np.abs(b["total"] - b["total"][0]).max()), b


def test_energy_books_close_for_one_grain_on_one_tether():
    """Kinetic + contact spring (k_n delta^2/2) + tether spring (k_w z_w^2/2) energy plus the
    dissipation accumulated by the contact and tether dashpots (eta_n v_n^2 + eta_w v_w^2,
    trapezoid rule on the per-step values) stays at the initial kinetic energy u0^2/2
    (head-on, so the tangential terms vanish although mu = 0.2).

    The residual peaks in the first step of the contact: the dashpot power jumps from 0 to
    eta_n u0^2 = 2.88 there, which the explicit scheme (force at the step's start) and the
    trapezoid rule both see a fraction of a step late -- an O(dt) error, halving with dt.
    Once the contact is over the books close much better."""
    res, final = {}, {}
    for dt in (DT, DT / 2):
        sim, teth, _ = grain_on_tether(dt)
        res[dt], b = energy_residual(sim, teth, 3.0)
        final[dt] = abs(b["total"][-1] - b["total"][0])
        assert b["total"][0] == pytest.approx(0.5 * U0**2, rel=1e-14)
        assert b["dissipated"][-1] > 0.49  # the target took almost all of it (0.497)
        assert b["spin"] == 0.0
    # measured 3.3e-3 (dt) and 1.5e-3 (dt/2) of E0 = 1/2 (0.7 % and 0.3 %)
    assert res[DT] < 7e-3
    assert res[DT / 2] < 0.6 * res[DT]
    assert final[DT] < 2e-4  # measured 6.5e-5 at t = 3 (1.8e-6 at dt/2)


@pytest.mark.filterwarnings("ignore:dt = .* is larger than")
def test_energy_and_momentum_books_of_a_bonded_patch():
    """A 19-particle bonded target (seed 002's particles "connected to each other and with
    their own initial positions") hit off-centre, 10 degrees from the normal, at u0: the
    grain touches three wall particles, two at a time, over t = 0.01 ... 0.58.

    Energy: kinetic + contact springs + ``Tethers.potential_energy`` (anchor and bond
    springs) + dissipation (contact dashpots eta_n v_n^2, anchor dashpots eta_w |v|^2, bond
    dashpots eta_w (v_rel . n)^2) stays at u0^2/2; as for one tether the residual peaks at
    first touch and is O(dt). mu = 0, so no tangential force or spin enters.

    Momentum: contacts and bonds are internal, so the total momentum changes only by the
    impulse of the anchor forces ``-k_w (x - x_anchor) - eta_w v``.

    (The filtered warning: Tethers bounds a bonded particle's damping rate by Gershgorin,
    (1 + 2 z) eta_w = 187 for z = 6 bonds, and warns for dt > 1/(5 * 187) = 0.0011, so the
    seed's own dt = 0.002 warns. The patch's largest damping rate is in fact 90 (the
    largest eigenvalue of its damping matrix), dt * 90 = 0.18, well inside AB2's stable
    interval dt * rate < 1; the books below close at that dt.)"""
    res, final, books = {}, {}, {}
    for dt in (DT, DT / 2):
        sim, teth = patch_target(dt)
        assert teth.bond_ids.shape == (42, 2)  # nearest-neighbour bonds of the hexagon
        res[dt], books[dt] = energy_residual(sim, teth, 3.0)
        final[dt] = abs(books[dt]["total"][-1] - books[dt]["total"][0])
    for dt, b in books.items():
        assert b["total"][0] == pytest.approx(0.5 * U0**2, rel=1e-14)
        assert b["spin"] == 0.0
        assert b["dissipated"][-1] > 0.35  # 0.380; the grain leaves with 0.120
        # momentum: trapezoid impulse of the anchor forces vs. the change of momentum
        dp = b["momentum"] - b["momentum"][0]
        assert np.abs(dp).max() > 1.0  # the anchors absorb more than the grain brought
        err = np.abs(dp - b["impulse"]).max()
        # measured 2.3e-4 (dt) and 5.8e-5 (dt/2): second order, like the trapezoid rule
        assert err < {DT: 6e-4, DT / 2: 1.5e-4}[dt]
        # and exactly the AB2 sum (eq. B.21, first step Euler):
        # p_n - p_0 = dt (sum_{k<n} F_k + (F_{n-1} - F_0) / 2); measured 3e-15
        f = b["anchor"]
        ab2 = dt * (np.cumsum(f[:-1], axis=0) + 0.5 * (f[:-1] - f[0]))
        np.testing.assert_allclose(dp[1:], ab2, rtol=0, atol=1e-12)
    # measured 2.3e-3 (dt) and 1.1e-3 (dt/2) of E0 = 1/2
    assert res[DT] < 5e-3
    assert res[DT / 2] < 0.6 * res[DT]
    assert final[DT] < 2e-4  # measured 6.7e-5 at t = 3 (1.2e-5 at dt/2)


# ------------------------------------------------------------------ orders of convergence
DTS = (2 * DT, DT, DT / 2, DT / 4)


def fitted_order(dts, errors) -> float:
    return float(np.polyfit(np.log(dts), np.log(errors), 1)[0])


def test_ab2_second_order_for_a_tethered_particle():
    """A tethered wall particle released from its anchor with a velocity (no contact): the
    linear damped oscillator; position and velocity at t = 1 against ``expm``."""
    v0 = np.array([0.3, -0.2, 1.0])
    ew = eta_w(ETA_N)
    a = np.array([[0.0, 1.0], [-KW, -ew]])
    errors = []
    for dt in DTS:
        st = ParticleState(3, Box(np.full(3, -10.0), np.full(3, 10.0), (False,) * 3))
        st.add_particles([[0.0, 0.0, 0.0]], 0.5, mass=1.0, body=0, v=[v0])
        sim = Simulation(st, dt, None, integrator=AdamsBashforth2())
        sim.add_force(Tethers(st.id, KW, ew))
        sim.run(int(round(1.0 / dt)))
        exact = np.array([expm(a * sim.time) @ [0.0, u] for u in v0])
        errors.append(max(np.abs(st.x[0] - exact[:, 0]).max(),
                          np.abs(st.v[0] - exact[:, 1]).max()))
    order = fitted_order(DTS, errors)
    assert 1.95 < order < 2.05  # measured 2.0008 (errors 3.3e-6 ... 5.2e-8)
    assert errors[1] < 2e-6  # measured 8.3e-7 at the seed's dt


def test_ab2_second_order_through_a_contact_without_dashpot():
    """Grain on the tethered particle with eta_n = 0: the contact force has a kink, not a
    jump, at touch and separation, and the whole state at t = 1 (after the contact)
    converges at second order. The kink's O(dt^2) error depends on where in a step the
    separation falls, so the error is averaged over touch phases before fitting."""
    errors = []
    for dt in DTS:
        e = []
        for phase in (0.1, 0.37, 0.63, 0.9):
            sim, _, gap = grain_on_tether(dt, phase=phase, eta_n=0.0, eta_wall=eta_w(ETA_N))
            rec = record_head_on(sim, int(round(1.0 / dt)))
            exact = ExactHeadOn(gap, eta_n=0.0, eta_wall=eta_w(ETA_N), t_end=1.1)
            e.append(np.abs(rec[-1, 1:] - exact(rec[-1, 0])[0]).max())
        errors.append(np.sqrt(np.mean(np.square(e))))
    order = fitted_order(DTS, errors)
    # measured 1.90 (rms errors 1.1e-3, 3.1e-4, 8.3e-5, 2.1e-5: ratios 3.6, 3.7, 3.9 -> 4)
    assert 1.75 < order < 2.25


def test_ab2_restitution_is_first_order_with_the_dashpot():
    """With the contact dashpot on, the force jumps by eta_n u0 at first touch (and at
    separation), and a fixed step cannot place the jump: the rebound velocity (the
    grain-on-tether restitution) has an O(dt) error whose sign and size depend on where in
    a step touch and separation fall. Its envelope over touch phases falls like dt, not
    dt^2 -- the second order of AB2 holds for the smooth parts only (module docstring)."""
    envelope = []
    for dt in DTS:
        errs = []
        for phase in np.linspace(0.05, 0.95, 8):
            sim, _, gap = grain_on_tether(dt, phase=phase)
            rec = record_head_on(sim, int(round(0.3 / dt)))
            exact = ExactHeadOn(gap, t_end=0.3)
            errs.append(rec[-1, 2] - exact(exact.contacts[0][1])[0, 1])
        envelope.append(np.abs(errs).max())
    order = fitted_order(DTS, envelope)
    # measured 1.09 (envelopes 4.1e-3, 2.4e-3, 8.5e-4, 4.6e-4 u0, the grain rebounding at
    # 0.070 u0); second order would be 2
    assert 0.8 < order < 1.4
    assert envelope[1] < 6e-3 * U0  # measured 2.4e-3 at the seed's dt
