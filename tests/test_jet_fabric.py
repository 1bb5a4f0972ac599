"""Contact fabric next to a jet's target (grainflow.analysis.jet.fabric): coordination, the
fabric tensor in cylindrical components, its normal-force-weighted form and the sliding
fraction, on hand-built contact listings whose answers are known."""

from __future__ import annotations

import numpy as np
import pytest

from grainflow.analysis.jet.fabric import pool_fabrics, ring_fabric_3d
from grainflow.frame import PAIR, WALL, Box, Contacts, Frame

R_TAR = 10.0  # five rings of width 2


def frame(pos, pairs, forces, *, types=None, time=0.0):
    """Grains at ``pos`` (ids 100, ...); one contact per ``pairs`` entry (i, j indices) with
    the force on i; branch vectors from the positions."""
    pos = np.asarray(pos, dtype=float)
    n = pos.shape[0]
    i = np.array([p[0] for p in pairs], dtype=np.int64)
    j = np.array([p[1] for p in pairs], dtype=np.int64)
    contacts = Contacts(i + 100, j + 100, np.asarray(forces, dtype=float), pos[i] - pos[j],
                        np.full(i.size, PAIR, np.int8))
    return Frame(step=0, time=time, box=Box(pos.min(axis=0) - 5, pos.max(axis=0) + 5,
                                            (False,) * 3),
                 id=np.arange(n, dtype=np.int64) + 100,
                 type=np.zeros(n, np.int32) if types is None else np.asarray(types, np.int32),
                 body=-np.ones(n, np.int64), radius=np.full(n, 0.5), mass=np.ones(n),
                 position=pos, velocity=np.zeros((n, 3)), omega=np.zeros((n, 3)),
                 contacts=contacts)


def test_a_vertical_contact_at_the_cap_and_a_tilted_one_below_it():
    """Two columns in ring 1 (r = 3): a vertical contact sliding (|F_t| = mu f_n), and one
    tilted in the r-z plane by 45 degrees with |F_t| = mu f_n / 4. Every grain is in ring 1,
    so Z = 2 x 2 / 4; the normals' rz fabric is (0 + 1/2) / 2; the sliding fraction 1/2."""
    mu = 0.5
    s = np.sqrt(0.5)
    pos = [[3.0, 0.0, 1.0], [3.0, 0.0, 2.0],             # vertical pair, along x = r
           [0.0, 3.0, 1.0], [0.0, 3.0 + s, 1.0 + s]]    # tilted pair, along y = r there
    vertical = [0.0, mu * 2.0, -2.0]  # f_n = 2 along -z, F_t = mu f_n along theta
    n = np.array([0.0, -s, -s])  # from grain 3 to grain 2
    t = np.array([0.0, s, -s])
    tilted = 4.0 * n + 0.25 * mu * 4.0 * t
    fab = ring_fabric_3d([frame(pos, [(0, 1), (2, 3)], [vertical, tilted])], R_TAR, mu)
    assert fab.contacts.tolist() == [0, 2, 0, 0, 0]
    assert fab.coordination[1] == pytest.approx(1.0)
    assert fab.fabric[1, 2, 2] == pytest.approx((1.0 + 0.5) / 2)
    assert fab.fabric[1, 0, 2] == pytest.approx(0.25)  # n_r n_z = 1/2 for the tilted one
    assert np.trace(fab.fabric[1]) == pytest.approx(1.0)
    assert fab.sliding[1] == pytest.approx(0.5)
    assert fab.normal_force[1] == pytest.approx(3.0)
    # weights f_n |b|: 2 x 1 (vertical) and 4 x 1 (tilted)
    assert fab.force_fabric[1, 0, 2] == pytest.approx(4.0 * 0.5 / 6.0)
    assert fab.normal_force_mu[1] == pytest.approx(-3.0 * (2.0 / 6.0))
    assert np.isnan(fab.coordination[0])  # no grain there


def test_contacts_with_the_target_and_outside_the_layer_are_left_out_and_frames_chosen():
    """A contact with a target particle (type 2), one above the layer and a wall contact
    are not counted; frames outside the window are skipped; without friction the sliding
    fraction is nan."""
    pos = [[3.0, 0.0, 1.0], [3.0, 0.0, 2.0], [3.0, 0.0, -0.5], [5.0, 0.0, 7.0],
           [5.0, 0.0, 8.0]]
    f = frame(pos, [(0, 1), (0, 2), (3, 4)], [[0, 0, -1.0], [0, 0, 1.0], [0, 0, -1.0]],
              types=[0, 0, 2, 0, 0], time=1.0)
    c = f.contacts
    with_wall = Contacts(np.r_[c.i, 100], np.r_[c.j, 0], np.r_[c.force, [[1.0, 0, 0]]],
                         np.r_[c.branch, [[0.5, 0, 0]]], np.r_[c.kind, WALL].astype(np.int8))
    f = Frame(**{**f.__dict__, "contacts": with_wall})
    late = Frame(**{**f.__dict__, "time": 5.0})
    fab = ring_fabric_3d([f, late], R_TAR, 0.0, window=(0.0, 2.0))
    assert fab.frames == 1
    assert fab.contacts.tolist() == [0, 1, 0, 0, 0]
    assert np.isnan(fab.sliding).all()
    with pytest.raises(ValueError, match="no frame in the window"):
        ring_fabric_3d([f], R_TAR, 0.0, window=(3.0, 4.0))


def test_pooled_replicas_are_their_frames_counted_together():
    """pool_fabrics of two runs' fabrics equals the fabric of both runs' frames at once:
    Z, both fabrics, the sliding fraction and the mean force."""
    rng = np.random.default_rng(4)

    def random_frame(time):
        pos = np.column_stack([rng.uniform(-9, 9, 40), rng.uniform(-9, 9, 40),
                               rng.uniform(0.2, 4.8, 40)])
        pairs = [(a, a + 1) for a in range(0, 39, 2)] + [(a, a + 3) for a in range(0, 30, 5)]
        forces = rng.normal(size=(len(pairs), 3))
        return frame(pos, pairs, forces, time=time)

    first = [random_frame(0.0), random_frame(1.0)]
    second = [random_frame(0.5), random_frame(2.0), random_frame(3.0)]
    pooled = pool_fabrics([ring_fabric_3d(first, R_TAR, 0.3), ring_fabric_3d(second, R_TAR, 0.3)])
    together = ring_fabric_3d(first + second, R_TAR, 0.3)
    for name in ("coordination", "fabric", "force_fabric", "sliding", "normal_force"):
        np.testing.assert_allclose(getattr(pooled, name), getattr(together, name), rtol=1e-12,
                                   err_msg=name)
    assert pooled.frames == 5 and pooled.contacts.tolist() == together.contacts.tolist()
