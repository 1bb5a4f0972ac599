"""Figures of the coarse-grained fields and the rheology (grainflow.plotting.cg_plots): each
function writes a readable PNG for Cartesian, slab, cylindrical and polar grids and for fitted
mu(I) / phi(I) data, and rejects bad arguments with a ValueError naming the argument."""

from __future__ import annotations

from math import pi

import numpy as np
import pytest
from matplotlib.image import imread

from grainflow.analysis.cg import Cartesian, Cylindrical, Polar, coarse_grain
from grainflow.analysis.rheology import (fit_divergence, fit_mu_linear, fit_mu_of_I,
                                         fit_mu_power_law, mu_of_I, phi_of_I)
from grainflow.frame import Box, Frame
from grainflow.plotting.cg_plots import (plot_field_map, plot_mu_of_I, plot_phi_of_I,
                                         plot_profiles, plot_velocity_distributions)

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def make_frames(dim, n_frames, rng, *, n=300, lo=-2.0, hi=2.0):
    """Random grains in a box with a shear flow v_0 = x_1 plus noise, one frame per step."""
    frames = []
    for step in range(n_frames):
        pos = rng.uniform(lo, hi, size=(n, dim))
        vel = rng.normal(scale=0.1, size=(n, dim))
        vel[:, 0] += pos[:, 1]
        frames.append(Frame(step=step, time=float(step), box=Box(np.full(dim, lo - 1),
                                                                 np.full(dim, hi + 1),
                                                                 (False,) * dim),
                            id=np.arange(n, dtype=np.int64), type=np.zeros(n, np.int32),
                            body=-np.ones(n, np.int64), radius=np.full(n, 0.05),
                            mass=np.ones(n), position=pos, velocity=vel,
                            omega=np.zeros((n, 3)), contacts=None))
    return frames


def assert_png(path):
    """A PNG file that matplotlib reads back as an RGBA image of figure size."""
    assert path.exists()
    assert path.read_bytes()[:8] == PNG_SIGNATURE
    image = imread(path)
    assert image.ndim == 3 and image.shape[2] == 4
    assert 300 <= image.shape[0] <= 3000 and 300 <= image.shape[1] <= 3000
    assert np.ptp(image[..., :3]) > 0  # something was drawn


@pytest.fixture(scope="module")
def grids():
    rng = np.random.default_rng(3)
    frames2, frames3 = make_frames(2, 8, rng), make_frames(3, 2, rng)
    edges = np.linspace(-2, 2, 7)
    return {
        "cartesian": coarse_grain(frames2, Cartesian([edges, edges]), contacts=False),
        "slab": coarse_grain(frames2, Cartesian([[-2, 2], np.linspace(-2, 2, 9)]), blocks=4,
                             contacts=False),
        "slab_b": coarse_grain(frames2, Cartesian([[-2, 0], np.linspace(-2, 2, 9)]), blocks=4,
                               contacts=False),
        "cylindrical": coarse_grain(frames3, Cylindrical(np.linspace(0, 2, 5),
                                                         np.linspace(-2, 2, 6)),
                                    contacts=False),
        "polar": coarse_grain(frames2, Polar(np.linspace(0, 2, 5), np.linspace(0, 2 * pi, 9)),
                              contacts=False),
        "polar_r": coarse_grain(frames2, Polar(np.linspace(0, 2, 6)), blocks=2, contacts=False),
    }


# --- field maps ------------------------------------------------------------------------------

@pytest.mark.parametrize("grid, name, component", [
    ("cartesian", "packing_fraction", None),
    ("cartesian", "velocity", 0),
    ("cartesian", "kinetic_stress", (0, 1)),
    ("cylindrical", "number_density", None),
    ("cylindrical", "stress", (0, 2)),
    ("polar", "velocity", 1),
    ("polar", "temperature", None),
])
def test_field_map_writes_png(grids, tmp_path, grid, name, component):
    out = plot_field_map(grids[grid], name, tmp_path / "maps" / f"{grid}_{name}.png",
                         component=component, title=f"{grid} {name}")
    assert out == tmp_path / "maps" / f"{grid}_{name}.png"
    assert_png(out)


@pytest.mark.parametrize("kwargs, argument", [
    ({"name": "velocity"}, "component"),
    ({"name": "pressure", "component": 0}, "component"),
    ({"name": "stress", "component": 1}, "component"),
    ({"name": "stress", "component": (0, 2)}, "component"),
    ({"name": "speed"}, "name"),
])
def test_field_map_rejects_bad_components(grids, tmp_path, kwargs, argument):
    name = kwargs.pop("name")
    with pytest.raises(ValueError, match=rf"^{argument}:"):
        plot_field_map(grids["cartesian"], name, tmp_path / "bad.png", **kwargs)


def test_field_map_needs_two_resolved_coordinates(grids, tmp_path):
    with pytest.raises(ValueError, match=r"^fields:.*two resolved"):
        plot_field_map(grids["slab"], "pressure", tmp_path / "bad.png")


# --- profiles --------------------------------------------------------------------------------

def test_slab_profiles_with_error_bands(grids, tmp_path):
    slab = grids["slab"]
    assert np.any(np.isfinite(slab.errors("velocity")))
    out = plot_profiles([slab, grids["slab_b"]], ["packing_fraction", "velocity", "stress"],
                        tmp_path / "slab.png", components=[None, 0, (0, 1)],
                        labels=["layer (a)", "layer (b)"])
    assert_png(out)


@pytest.mark.parametrize("grid, errors", [("slab", False), ("polar_r", True)])
def test_single_profile(grids, tmp_path, grid, errors):
    out = plot_profiles(grids[grid], "temperature", tmp_path / f"{grid}.png", errors=errors)
    assert_png(out)


@pytest.mark.parametrize("fields, names, kwargs, argument", [
    ("cartesian", "pressure", {}, "fields"),
    ("slab+polar", "pressure", {}, "fields"),
    ("slab", "velocity", {}, "components"),
    ("slab", ["velocity", "pressure"], {"components": [0]}, "components"),
    ("slab", ["pressure", "speed"], {}, "names"),
    ("slab", [], {}, "names"),
    ("slab", "pressure", {"labels": ["a", "b"]}, "labels"),
])
def test_profiles_reject_bad_arguments(grids, tmp_path, fields, names, kwargs, argument):
    chosen = [grids[k] for k in fields.split("+")]
    with pytest.raises(ValueError, match=rf"^{argument}:"):
        plot_profiles(chosen, names, tmp_path / "bad.png", **kwargs)


# --- rheology --------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def mu_data():
    rng = np.random.default_rng(11)
    I = np.geomspace(1e-3, 1.0, 14)
    err = np.full(I.size, 0.01)
    mu = mu_of_I(I, 0.015, 0.52, 0.082) + rng.normal(scale=0.01, size=I.size)
    return I, mu, err


def test_mu_of_I_with_fits(mu_data, tmp_path):
    I, mu, err = mu_data
    fits = [fit_mu_of_I(I, mu, err), fit_mu_power_law(I, mu, err, mu_s=0.0),
            fit_mu_linear(I[:5], mu[:5], err[:5])]
    assert_png(plot_mu_of_I(I, mu, tmp_path / "mu.png", mu_err=err, fits=fits))
    assert_png(plot_mu_of_I(I, mu, tmp_path / "mu_lin.png", fits=fits[:2], labels=["JFP", "b"],
                            xlog=False))


@pytest.mark.parametrize("kwargs, argument", [
    ({"mu": np.ones(3)}, "mu"),
    ({"mu_err": np.ones(3)}, "mu_err"),
    ({"I": -np.ones(14)}, "I"),
    ({"fits": ["not a fit"]}, "fits"),
    ({"labels": ["a", "b"]}, "labels"),
])
def test_mu_of_I_rejects_bad_arguments(mu_data, tmp_path, kwargs, argument):
    I, mu, _ = mu_data
    fit = fit_mu_linear(I, mu)
    args = {"I": I, "mu": mu, "fits": [fit], **kwargs}
    with pytest.raises(ValueError, match=rf"^{argument}:"):
        plot_mu_of_I(args.pop("I"), args.pop("mu"), tmp_path / "bad.png", **args)


def test_phi_of_I_with_fit(tmp_path):
    rng = np.random.default_rng(5)
    I = np.geomspace(1e-4, 0.05, 12)
    err = np.full(I.size, 0.002)
    phi = phi_of_I(I, 0.834, 3.94, 1.36) + rng.normal(scale=0.002, size=I.size)
    fit = fit_divergence(I, phi, err)
    assert_png(plot_phi_of_I(I, phi, tmp_path / "phi.png", phi_err=err, fit=fit))
    assert_png(plot_phi_of_I(I, phi, tmp_path / "phi_T.png", label="I_T"))
    with pytest.raises(ValueError, match="^phi_err:"):
        plot_phi_of_I(I, phi, tmp_path / "bad.png", phi_err=err[:3])
    with pytest.raises(ValueError, match="^fit:"):
        plot_phi_of_I(I, phi, tmp_path / "bad.png", fit=fit_mu_linear(I, phi))


# --- velocity distributions ------------------------------------------------------------------

def test_velocity_distributions(tmp_path):
    rng = np.random.default_rng(2)
    v = np.column_stack([rng.normal(size=4000), rng.laplace(size=4000), rng.normal(size=4000)])
    assert_png(plot_velocity_distributions(v, tmp_path / "vdf.png"))
    assert_png(plot_velocity_distributions(v[:, 0], tmp_path / "vdf1.png", components=["x"],
                                           bins=30))
    with pytest.raises(ValueError, match="^components:"):
        plot_velocity_distributions(v, tmp_path / "bad.png", components=("x", "y"))
