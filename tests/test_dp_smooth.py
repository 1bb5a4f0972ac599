"""Smooth contacts between deformable rings (:class:`grainflow.engine.dp_edges.EdgeContacts`;
seed 003 Appendix A, eq. 9, 12): forces are the exact gradient of the energy, normal to the
edge without friction, conserve energy and momentum in a collision, are bitwise the same on
any thread count and in the compiled step loop, and bad parameters are named.

Rings of 16 vertices and area 1 (rest edge l0 = 0.223, edge thickness 0.2 l0 = 0.045, so
``sigma = 0.045``) built by :func:`grainflow.insertion.dp_bodies.add_rings` with
``contact="smooth"``, in a simulation without pair interaction.
"""

from __future__ import annotations

import numba
import numpy as np
import pytest

from grainflow.engine.deformable import ShapeForce
from grainflow.engine.dp_edges import REACH_ERROR, EdgeContacts
from grainflow.engine.simulation import Simulation
from grainflow.frame import Box
from grainflow.insertion.dp_bodies import add_rings
from grainflow.kernels.dp_edges import CAP, STRIP
from grainflow.rings import regular_polygon, rest_length
from grainflow.state import ParticleState

AREA = 1.0
L0 = float(rest_length(AREA, 16))
#: Circumradius of the rings.
RADIUS = float(np.linalg.norm(regular_polygon(AREA, 16)[0]))


def _simulation(dt: float = 1e-4, skin: float = 0.005) -> Simulation:
    """An empty 2D box for rings (skin: about 0.2 vertex radii, the engine's default)."""
    st = ParticleState(2, Box(np.array([-5.0, -5.0]), np.array([5.0, 5.0]), (False, False)))
    return Simulation(st, dt, skin=skin, threads=1)


def _terms(sim: Simulation, edges: EdgeContacts) -> tuple:
    """(p, a, b, kind, t, d, sigma, force, branch) of every term in contact."""
    return edges._contact_list(sim.context)


def _overlapping_rings(mu_k: float = 0.0, kinetic_on: str = "full") -> tuple:
    """Three rings touching in four places: ring B's corner in ring A's corner wedge (an end
    cap), A's corner on B's edge near its end (t ~ 0.995), ring C's corner on A's edge near
    its start (t = 0.03) and A's corner on C's edge near its start (t ~ 0.01); positions
    jittered by 1e-4 so that nothing is symmetric."""
    sim = _simulation()
    a_ring = regular_polygon(AREA, 16, 0.0)
    edge4 = (a_ring[5] - a_ring[4]) / L0
    outward4 = np.array([edge4[1], -edge4[0]])
    tip_c = a_ring[4] + 0.03 * outward4 + 0.03 * L0 * edge4
    angle_b, angle_c = np.pi + 0.3, -np.pi / 2 + 0.15
    centre_b = a_ring[0] + np.array([0.03, 0.002]) - regular_polygon(AREA, 16, angle_b)[0]
    centre_c = tip_c - regular_polygon(AREA, 16, angle_c)[0]
    add_rings(sim, np.array([[0.0, 0.0], centre_b, centre_c]), AREA, contact="smooth",
              angles=np.array([0.0, angle_b, angle_c]))
    rng = np.random.default_rng(3)
    sim.state.x[:, :2] += 1e-4 * rng.standard_normal((sim.state.n, 2))
    sim.state.v[:, :2] = 0.3 * rng.standard_normal((sim.state.n, 2))
    edges = sim.add_force(EdgeContacts(1.0, mu_k, kinetic_on))
    sim.compute_forces()
    return sim, edges


def test_forces_are_minus_the_energy_gradient() -> None:
    """Central differences of the energy (seed 003 eq. 9 summed over the terms) match the
    forces to 1e-7 of the largest force, on a configuration with an end cap and strips near
    t = 0 and t = 1 (1e-3 l0 and more from every boundary of the rule)."""
    sim, edges = _overlapping_rings()
    _, _, _, kind, t, d, sigma, _, _ = _terms(sim, edges)
    assert np.any(kind == CAP)
    assert np.any((kind == STRIP) & (t < 0.05)) and np.any((kind == STRIP) & (t > 0.95))
    assert np.all(d < sigma)
    st = sim.state
    force = st.force[:, :2].copy()
    h = 1e-6
    numeric = np.zeros_like(force)
    for i in range(st.n):
        for c in range(2):
            x0 = st.x[i, c]
            st.x[i, c] = x0 + h
            up = edges.potential_energy(sim.context)
            st.x[i, c] = x0 - h
            down = edges.potential_energy(sim.context)
            st.x[i, c] = x0
            numeric[i, c] = -(up - down) / (2.0 * h)
    scale = np.abs(force).max()
    assert scale > 1.0
    assert np.abs(force - numeric).max() <= 1e-7 * scale


def test_sliding_vertex_feels_a_normal_force() -> None:
    """A corner of ring B pressed on the middle of an edge of ring A and sliding along it
    feels exactly the harmonic force along the edge's normal (mu_k = 0); the reaction is
    split half and half between the edge's ends. With kinetic friction on the tangential
    part the extra force is -mu_k times the sliding velocity."""
    def build(mu_k: float) -> tuple:
        sim = _simulation()
        mid = RADIUS * np.cos(np.pi / 16)  # edge 0 of A is vertical, its middle on the x axis
        tip_b = regular_polygon(AREA, 16, np.pi)[0]
        gap = 0.7 * 0.2 * L0  # 0.7 sigma
        add_rings(sim, np.array([[0.0, 0.0], [mid + gap - tip_b[0], 0.0]]), AREA,
                  contact="smooth", angles=np.array([-np.pi / 16, np.pi]),
                  v=np.array([[0.0, 0.0], [0.0, 0.4]]))
        edges = sim.add_force(EdgeContacts(2.0, mu_k, "tangential"))
        sim.compute_forces()
        return sim, edges

    sim, edges = build(0.0)
    p, a, b, kind, t, d, sigma, force, branch = _terms(sim, edges)
    assert p.size == 1 and kind[0] == STRIP and abs(t[0] - 0.5) < 1e-9
    st = sim.state
    along = st.x[b[0], :2] - st.x[a[0], :2]
    along /= np.linalg.norm(along)
    f = st.force[p[0], :2]
    magnitude = 2.0 / sigma[0] * (1.0 - d[0] / sigma[0])
    assert abs(f @ along) <= 1e-13 * magnitude
    assert f[0] == pytest.approx(magnitude, rel=1e-12)  # away from A, along +x
    np.testing.assert_allclose(st.force[a[0], :2], -(1.0 - t[0]) * f, rtol=1e-12)
    np.testing.assert_allclose(st.force[b[0], :2], -t[0] * f, rtol=1e-12)

    rough, rough_edges = build(0.5)
    q = _terms(rough, rough_edges)[0]
    np.testing.assert_array_equal(q, p)
    slip = rough.state.force[q[0], :2] - f
    np.testing.assert_allclose(slip, [0.0, -0.5 * 0.4], atol=1e-12)


def test_other_particles_are_ignored() -> None:
    """A disk that is no ring vertex, sitting on a ring's edge, gets no edge force."""
    sim = _simulation()
    add_rings(sim, np.array([[0.0, 0.0]]), AREA, contact="smooth", angles=0.0)
    edge_mid = 0.5 * (regular_polygon(AREA, 16)[0] + regular_polygon(AREA, 16)[1])
    sim.add_particles(edge_mid[None, :], 0.05, density=1.0)
    edges = sim.add_force(EdgeContacts(1.0))
    sim.compute_forces()
    assert sim.neighbors.n_pairs > 0
    assert _terms(sim, edges)[0].size == 0
    assert not sim.state.force.any()


def test_pair_terms_are_the_full_rule_on_every_listed_pair() -> None:
    """The force pass tests each listed pair's distance to both edge segments before it runs
    the vertex-edge rule. On a pressed, jittered 4 x 4 packing (many terms in contact, many
    listed pairs that are not) every slot equals what the unfiltered rule gives for that
    (vertex, edge): :func:`grainflow.kernels.dp_edges.edge_contact_list` runs it on every
    listed pair."""
    from grainflow.kernels.dp_edges import edge_pair_terms, ring_edge_vectors

    sim = _simulation()
    spacing = 1.9 * RADIUS  # closer than touching: every neighbour pair of rings overlaps
    grid = np.array([[ix, iy] for ix in range(4) for iy in range(4)], dtype=float) * spacing
    rng = np.random.default_rng(11)
    add_rings(sim, grid - grid.mean(axis=0) + 0.02 * rng.standard_normal(grid.shape), AREA,
              contact="smooth", angles=rng.uniform(0, 2 * np.pi, len(grid)))
    sim.state.x[:, :2] += 0.01 * rng.standard_normal((sim.state.n, 2))
    sim.state.v[:, :2] = 0.3 * rng.standard_normal((sim.state.n, 2))
    edges = sim.add_force(EdgeContacts(1.0, 0.4, "tangential"))
    sim.compute_forces()
    a = edges._args(sim.context)
    ring_edge_vectors(a[3], a[5], a[10], a[11], a[12])
    edge_pair_terms(*a[:15])
    slot = a[13]
    p, edge_start, _, _, t, _, _, force, _ = _terms(sim, edges)
    full = {(int(pi), int(ai)): (force[k, 0], force[k, 1], t[k])
            for k, (pi, ai) in enumerate(zip(p, edge_start))}
    rows = np.repeat(np.arange(sim.state.n), np.diff(a[8]))
    expected = np.zeros_like(slot)
    for k, (i, j) in enumerate(zip(rows, a[9])):
        expected[k, 0:3] = full.get((int(j), int(i)), (0.0, 0.0, 0.0))  # term 0: p = j
        expected[k, 3:6] = full.get((int(i), int(j)), (0.0, 0.0, 0.0))  # term 1: p = i
    touching = (expected[:, [0, 3]] != 0).any(axis=1)
    assert len(full) > 40 and (~touching).sum() > 5 * touching.sum()  # both kinds present
    np.testing.assert_array_equal(slot, expected)


def _collision(dt: float, mu_k: float = 0.0) -> tuple[Simulation, ShapeForce, EdgeContacts]:
    """Two rings meeting nearly head-on at relative speed 0.5, zero total momentum; bending
    rigidity keeps their corners convex (see the energy test)."""
    sim = _simulation(dt)
    add_rings(sim, np.array([[-0.6, 0.0], [0.6, 0.0]]), AREA, contact="smooth",
              angles=np.array([0.1, np.pi - 0.05]), v=np.array([[0.25, 0.0], [-0.25, 0.0]]))
    shape = sim.add_force(ShapeForce(100.0, 50.0, np.pi))  # k_b a0^2/pi = 1 at a0 = 1
    edges = sim.add_force(EdgeContacts(1.0, mu_k, "tangential"))
    return sim, shape, edges


def _energy_record(dt: float) -> tuple[np.ndarray, float, float, float]:
    """Total energy every 0.001 time units over one, and the peak edge-contact energy,
    relative overlap and momentum."""
    sim, shape, edges = _collision(dt)
    st = sim.state
    record = {"E": [], "edge": 0.0, "overlap": 0.0, "P": 0.0}

    def watch(ctx) -> None:
        u_edge = edges.potential_energy(sim.context)
        record["E"].append(st.kinetic_energy() + shape.potential_energy(sim.context) + u_edge)
        record["edge"] = max(record["edge"], u_edge)
        record["overlap"] = max(record["overlap"], edges.max_overlap(sim.context)[1])
        record["P"] = max(record["P"], float(np.abs(st.momentum()).max()))

    watch(None)
    sim.add_observer(watch, round(1e-3 / dt))
    sim.run(round(1.0 / dt))
    return np.array(record["E"]), record["edge"], record["overlap"], record["P"]


def test_collision_conserves_energy_and_momentum() -> None:
    """Without friction or drag, kinetic + shape + edge-contact energy is conserved up to
    velocity Verlet's O(dt^2) error: halving dt divides the largest deviation by about 4
    (3 to 5.5 allowed; a missing, doubled or discontinuous term would not shrink so, as it
    does not when rings without bending rigidity grow reflex corners, where the rule's
    energy steps), and at dt = t_contact/200 the deviation is below 1e-5 of the kinetic
    energy brought in. Momentum (zero) stays at round-off."""
    e1, edge_peak, overlap, p1 = _energy_record(2.5e-4)
    e2, _, _, p2 = _energy_record(1.25e-4)
    kinetic_in = 2 * 0.5 * AREA * 0.25**2
    assert edge_peak > 0.05 * kinetic_in and overlap > 0.15  # a real collision
    err1 = np.abs(e1 - e1[0]).max()
    err2 = np.abs(e2 - e2[0]).max()
    assert err2 < 1e-5 * kinetic_in
    assert 3.0 < err1 / err2 < 5.5
    assert max(p1, p2) < 1e-14


def test_bitwise_same_on_one_and_two_threads() -> None:
    """Forces (with tangential kinetic friction) are bitwise the same on 1 and 2 threads."""
    before = numba.get_num_threads()
    forces = []
    try:
        for threads in (1, 2):
            numba.set_num_threads(threads)
            sim, _ = _overlapping_rings(mu_k=0.7, kinetic_on="tangential")
            forces.append(sim.state.force.copy())
    finally:
        numba.set_num_threads(before)
    assert np.abs(forces[0]).max() > 1.0
    np.testing.assert_array_equal(forces[0], forces[1])


def test_compiled_loop_matches_python_steps() -> None:
    """A frictional collision stepped in Python, in the compiled loop on one thread and in
    the compiled loop on two threads ends in bitwise the same state."""
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("needs 2 numba threads")
    runs = []
    for fast, threads in ((False, 1), (True, 1), (True, 2)):
        sim, _, _ = _collision(2.5e-4, mu_k=0.05)
        sim.fast_path_min_steps = 0 if fast else 10**12
        sim.threads = threads
        sim.run(800)
        assert (sim._fast_path.steps_done > 400) == fast
        assert sim.rebuilds > 1
        order = np.argsort(sim.state.id)
        runs.append([sim.state.x[order], sim.state.v[order], sim.state.force[order]])
    for other in runs[1:]:
        for ref, got in zip(runs[0], other):
            np.testing.assert_array_equal(ref, got)


def test_an_edge_longer_than_the_reach_is_refused() -> None:
    """An edge stretched past ``reach_factor * l0`` minus the thickness stops the run, in
    Python and in the compiled loop."""
    sim = _simulation()
    idx = add_rings(sim, np.array([[0.0, 0.0]]), AREA, contact="smooth", angles=0.0)
    sim.add_force(EdgeContacts(1.0))
    sim.state.x[idx[0, 0], 0] += L0  # its two edges: 1.55 l0 > 1.5 l0 - 0.2 l0
    with pytest.raises(ValueError, match="reach_factor"):
        sim.compute_forces()

    sim = _simulation(1e-3, skin=1.0)  # no list rebuild: the compiled loop runs on
    idx = add_rings(sim, np.array([[0.0, 0.0]]), AREA, contact="smooth", angles=0.0)
    sim.state.v[idx[0, 0], 0] = 2.0  # vertex 0 flies off: its edges stretch
    sim.add_force(EdgeContacts(1.0))
    sim.fast_path_min_steps = 0
    with pytest.raises(ValueError) as err:
        sim.run(100)
    assert str(err.value) == REACH_ERROR  # the compiled loop's message (Python's has numbers)


@pytest.mark.parametrize("kw, field", [
    ({"epsilon": 0.0}, "epsilon"), ({"epsilon": np.nan}, "epsilon"),
    ({"mu_k": -1.0}, "mu_k"), ({"kinetic_on": "normal"}, "kinetic_on"),
    ({"n_vertices": 2}, "n_vertices"), ({"n_vertices": 16.0}, "n_vertices"),
    ({"reach_factor": 1.0}, "reach_factor"), ({"reach_factor": np.inf}, "reach_factor"),
])
def test_bad_parameters_are_named(kw: dict, field: str) -> None:
    args = {"epsilon": 1.0, **kw}
    with pytest.raises(ValueError, match=f"^{field}:"):
        EdgeContacts(**args)
