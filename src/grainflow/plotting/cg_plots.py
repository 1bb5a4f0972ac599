"""Figures of the coarse-grained fields (:mod:`grainflow.analysis.cg`) and of the rheology
built on them (:mod:`grainflow.analysis.rheology`), after seed 002 (H. Sano, PhD thesis
(2013)): field maps, profiles with block error bands, mu*(I) and phi(I) with their fits
(Figs. 6.3-6.6) and the scaled velocity distributions (Fig. 5.8).

Each function takes data and a path, writes a PNG and returns the path. Figures are drawn on
an Agg canvas without pyplot, so no global backend is changed. Quantities are in the caller's
simulation units, written on the axes as length ``d``, mass ``m`` and time ``t_0``; angles are
in radians.

Components are chosen by index into the field's component axes (``coordinates.components``):
``component=1`` is v_y (v_theta in polar or cylindrical components), ``component=(0, 1)`` is
sigma_xy (sigma_r,theta); cylindrical tensors are ordered (r, theta, z), so (0, 2) is sigma_rz.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.axes import Axes
from matplotlib.collections import QuadMesh
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from numpy.typing import ArrayLike

from grainflow.analysis.cg import FIELDS, CGFields, Cylindrical, Polar
from grainflow.analysis.rheology import (DivergenceFit, MuLinearFit, MuOfIFit, MuPowerLawFit,
                                         exponential_vdf, flatness, gaussian_vdf,
                                         velocity_distribution)
from grainflow.plotting.figures import new_figure, save_figure

__all__ = ["plot_field_map", "plot_mu_of_I", "plot_phi_of_I", "plot_profiles",
           "plot_velocity_distributions"]

#: A component of a field: None (scalar field), an index (vector), an index pair (tensor).
Component = int | tuple[int, int] | None

#: A fitted friction law.
MuFit = MuOfIFit | MuPowerLawFit | MuLinearFit

_MARKERS = "os^Dv<>p*hX"

#: Field name -> (TeX symbol, unit as a function of the dimension D; "" if dimensionless).
_FIELD_LABELS = {
    "number_density": ("n", lambda dim: f"d^{{-{dim}}}"),
    "mass_density": (r"\rho", lambda dim: f"m\\,d^{{-{dim}}}"),
    "packing_fraction": (r"\phi", lambda dim: ""),
    "momentum": ("p", lambda dim: f"m\\,d^{{{1 - dim}}}\\,t_0^{{-1}}"),
    "velocity": ("v", lambda dim: r"d\,t_0^{-1}"),
    "kinetic_stress": (r"\sigma^{k}", lambda dim: _stress_unit(dim)),
    "contact_stress": (r"\sigma^{c}", lambda dim: _stress_unit(dim)),
    "stress": (r"\sigma", lambda dim: _stress_unit(dim)),
    "pressure": ("P", lambda dim: _stress_unit(dim)),
    "temperature": ("T", lambda dim: r"m\,d^{2}\,t_0^{-2}"),
    "temperature_components": ("T", lambda dim: r"m\,d^{2}\,t_0^{-2}"),
    "strain_rate": ("D", lambda dim: r"t_0^{-1}"),
}

#: Fit class -> its parameters as (attribute, TeX symbol); errors are ``<attribute>_err``.
_FIT_PARAMETERS = {
    MuOfIFit: (("mu_s", r"\mu_s"), ("mu_max", r"\mu_{max}"), ("I0", "I_0")),
    MuPowerLawFit: (("mu_s", r"\mu_s"), ("b", "b"), ("beta", r"\beta")),
    MuLinearFit: (("a", "a"),),
    DivergenceFit: (("phi_c", r"\phi_c"), ("a", "a"), ("alpha", r"\alpha")),
}

_FIT_NAMES = {
    MuOfIFit: r"$\mu(I)$ law $\mu_s + (\mu_{max}-\mu_s)/(1+I_0/I)$",
    MuPowerLawFit: r"power law $\mu_s + b I^\beta$",
    MuLinearFit: r"linear $a I$",
}


# --- figure helpers --------------------------------------------------------------------------

def _as_list(items: object) -> list:
    """A single item or a sequence of items (not a string) as a list."""
    return list(items) if isinstance(items, Sequence) and not isinstance(items, str) else [items]


def _labels(labels: Sequence[str] | None, n: int, default: Sequence[str]) -> list[str]:
    """``labels`` checked to hold ``n`` entries, or ``default``."""
    if labels is None:
        return list(default)
    if len(labels) != n:
        raise ValueError(f"labels: expected {n} labels, got {len(labels)}")
    return list(labels)


# --- labels and units ------------------------------------------------------------------------

def _stress_unit(dim: int) -> str:
    """Stress (energy per length^D): m d^(2-D) t0^-2."""
    return r"m\,t_0^{-2}" if dim == 2 else rf"m\,d^{{{2 - dim}}}\,t_0^{{-2}}"


def _tex(name: str) -> str:
    """A coordinate or component name in TeX (``theta`` -> ``\\theta``)."""
    return r"\theta" if name == "theta" else name


def _axis_names(fields: CGFields) -> tuple[str, ...]:
    """Names of the grid's coordinates, in the order of ``coordinates.edges``."""
    coords = fields.coordinates
    if isinstance(coords, Cylindrical):
        return ("r", "z")
    return coords.components


def _axis_label(name: str) -> str:
    """Axis label of a grid coordinate with its unit."""
    return r"$\theta$ [rad]" if name == "theta" else f"${name}$ [$d$]"


def _field_label(fields: CGFields, name: str, component: Component) -> str:
    """E.g. ``$\\sigma_{xy}$ [$m\\,t_0^{-2}$]`` for the stress in 2D."""
    base = name
    suffix = ""
    if name.startswith("contact_stress_"):
        base, suffix = "contact_stress", name.removeprefix("contact_stress_")
    symbol, unit = _FIELD_LABELS[base]
    if suffix:
        symbol = rf"\sigma^{{c,\mathrm{{{suffix}}}}}"
    names = fields.coordinates.components
    indices = () if component is None else np.atleast_1d(component)
    subscript = "".join(_tex(names[i]) for i in indices)
    text = f"${symbol}_{{{subscript}}}$" if subscript else f"${symbol}$"
    units = unit(fields.dim)
    return f"{text} [${units}$]" if units else text


def _format_pm(value: float, err: float) -> str:
    """``value \\pm err`` with the error to one significant figure (two if it starts with 1)."""
    if not (np.isfinite(err) and err > 0):
        return f"{value:.3g}"
    mantissa, exponent = f"{err:.0e}".split("e")
    decimals = max(0, (1 if mantissa == "1" else 0) - int(exponent))
    return rf"{value:.{decimals}f} \pm {err:.{decimals}f}"


def fit_parameters_text(fit: MuFit | DivergenceFit) -> str:
    """The fitted parameters with their errors, e.g. ``$\\mu_s = 0.015 \\pm 0.009$, ...``."""
    parts = []
    for attr, symbol in _FIT_PARAMETERS[type(fit)]:
        value = getattr(fit, attr)
        if attr == "mu_s" and getattr(fit, "mu_s_fixed", False):
            parts.append(f"${symbol} = {value:g}$ (fixed)")
        else:
            parts.append(f"${symbol} = {_format_pm(value, getattr(fit, attr + '_err'))}$")
    return ", ".join(parts)


# --- field access ----------------------------------------------------------------------------

def _check_name(name: str, arg: str) -> None:
    """ValueError naming ``arg`` unless ``name`` is a field of :data:`FIELDS`."""
    if name not in FIELDS:
        raise ValueError(f"{arg}: unknown field {name!r}; choose one of {', '.join(FIELDS)}")


def _select(values: np.ndarray, fields: CGFields, component: Component, arg: str) -> np.ndarray:
    """The scalar field, or one component of a vector/tensor field; ValueError naming ``arg``
    if ``component`` does not fit the field's component axes."""
    tail = values.shape[len(fields.shape):]
    index = () if component is None else tuple(np.atleast_1d(component))
    fits = len(index) == len(tail) and all(isinstance(i, (int, np.integer)) and 0 <= i < n
                                           for i, n in zip(index, tail))
    if not fits:
        kind = {0: "a scalar field: give None", 1: f"a vector field: give an index < {fields.dim}",
                2: f"a tensor field: give an index pair (a, b), each < {fields.dim}"}[len(tail)]
        raise ValueError(f"{arg}: {component!r} does not fit {kind}")
    return values[(Ellipsis, *index)] if index else values


# --- field maps ------------------------------------------------------------------------------

def _map_axes(fig: Figure, fields: CGFields) -> Axes:
    """Polar axes for an r-theta grid, plain axes otherwise."""
    if isinstance(fields.coordinates, Polar):
        return fig.add_subplot(projection="polar")
    return fig.add_subplot()


def _arc_edges(edges: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Theta edges cut into steps of at most 2 degrees, values repeated to match: polar
    pcolormesh joins cell corners by straight lines, so coarse bins would draw polygons."""
    steps = int(np.ceil(np.diff(edges).max() / np.radians(2.0)))
    fine = edges[:-1, None] + np.diff(edges)[:, None] * np.arange(steps) / steps
    return np.append(fine.ravel(), edges[-1]), np.repeat(values, steps, axis=1)


def _draw_polar(ax: Axes, fields: CGFields, values: np.ndarray, cmap: str,
                limits: dict) -> QuadMesh:
    """An r-theta grid on polar axes (theta the angle, r the radius from 0)."""
    r_edges, t_edges = fields.coordinates.edges
    theta, arcs = _arc_edges(t_edges, values)
    mesh = ax.pcolormesh(theta, r_edges, np.ma.masked_invalid(arcs), cmap=cmap,
                         shading="flat", **limits)
    ax.set_ylim(0.0, r_edges[-1])
    if t_edges[-1] - t_edges[0] < 2.0 * np.pi - 1e-9:
        ax.set_thetalim(t_edges[0], t_edges[-1])
    ax.yaxis.set_major_locator(MaxNLocator(4))
    ax.set_xlabel(r"$\theta$")
    ax.set_ylabel(r"$r$ [$d$]", labelpad=30)
    return mesh


def _draw_planar(ax: Axes, fields: CGFields, values: np.ndarray, cmap: str,
                limits: dict) -> QuadMesh:
    """A grid's first resolved coordinate horizontal, its second vertical, equal scales."""
    a, b = fields.coordinates.resolved
    edges, names = fields.coordinates.edges, _axis_names(fields)
    mesh = ax.pcolormesh(edges[a], edges[b], np.ma.masked_invalid(values).T, cmap=cmap,
                         shading="flat", **limits)
    ax.set_xlabel(_axis_label(names[a]))
    ax.set_ylabel(_axis_label(names[b]))
    ax.set_aspect("equal")
    return mesh


def _colour_scale(values: np.ndarray, cmap: str | None) -> tuple[str, dict]:
    """The colour map and limits: a diverging map centred on zero for data of both signs,
    viridis otherwise, unless ``cmap`` is given."""
    finite = values[np.isfinite(values)]
    signed = finite.size > 0 and finite.min() < 0 < finite.max()
    if not signed:
        return cmap or "viridis", {}
    top = float(np.abs(finite).max())
    return cmap or "RdBu_r", {"vmin": -top, "vmax": top}


def plot_field_map(
    fields: CGFields,
    name: str,
    path: str | Path,
    *,
    component: Component = None,
    title: str | None = None,
    cmap: str | None = None,
) -> Path:
    """Colour map of a field (or one component) over a grid with two resolved coordinates.

    Cells are drawn between the bin edges (pcolormesh); empty cells (NaN) are left blank.
    Cartesian grids use their axis names, cylindrical grids put r horizontal and z vertical,
    polar r-theta grids are drawn on polar axes.

    Parameters
    ----------
    fields : the coarse-grained fields; their grid must resolve exactly two coordinates.
    name : a field of :data:`~grainflow.analysis.cg.FIELDS`.
    path : output PNG path.
    component : None for scalar fields, an index for vectors (``1``: v_y), an index pair for
        tensors (``(0, 1)``: sigma_xy).
    title : figure title; default the field's name.
    cmap : matplotlib colour map; default a diverging map centred on zero for data of both
        signs, else viridis.
    """
    resolved = fields.coordinates.resolved
    if len(resolved) != 2:
        raise ValueError(f"fields: a map needs a grid with exactly two resolved coordinates, "
                         f"this one resolves {len(resolved)}")
    _check_name(name, "name")
    values = _select(fields.field(name), fields, component, "component")
    colours, limits = _colour_scale(values, cmap)
    fig = new_figure(1, width=5.0, height=4.2)
    ax = _map_axes(fig, fields)
    draw = _draw_polar if isinstance(fields.coordinates, Polar) else _draw_planar
    mesh = draw(ax, fields, values, colours, limits)
    fig.colorbar(mesh, ax=ax, label=_field_label(fields, name, component))
    ax.set_title(title if title is not None else name.replace("_", " "), fontsize=10)
    return save_figure(fig, path)


# --- profiles --------------------------------------------------------------------------------

def _profile_axis(field_list: list[CGFields]) -> str:
    """The name of the single resolved coordinate the grids share; ValueError otherwise."""
    names = set()
    for fields in field_list:
        resolved = fields.coordinates.resolved
        if len(resolved) != 1:
            raise ValueError(f"fields: a profile needs a grid with one resolved coordinate, "
                             f"got one resolving {len(resolved)}")
        names.add(_axis_names(fields)[resolved[0]])
    if len(names) != 1:
        raise ValueError(f"fields: the grids resolve different coordinates {sorted(names)}")
    return names.pop()


def _profile_components(names: str | Sequence[str],
                        components: Component | Sequence[Component]
                        ) -> list[tuple[str, Component]]:
    """(name, component) per panel: a single name takes a single component, a sequence of
    names a sequence of components of the same length."""
    name_list = [names] if isinstance(names, str) else list(names)
    if not name_list:
        raise ValueError("names: give at least one field name")
    for name in name_list:
        _check_name(name, "names")
    if isinstance(names, str):
        return [(names, components)]
    if components is None:
        return [(n, None) for n in name_list]
    if not isinstance(components, Sequence) or len(components) != len(name_list):
        raise ValueError(f"components: expected one component per name ({len(name_list)}), "
                         f"got {components!r}")
    return list(zip(name_list, components))


def _draw_profile(ax: Axes, fields: CGFields, name: str, component: Component, *,
                  colour: tuple, marker: str, label: str, errors: bool) -> None:
    x = fields.coordinates.centres[0]
    y = _select(fields.field(name), fields, component, "components")
    ax.plot(x, y, "-", marker=marker, ms=4, mfc="none", color=colour, lw=1.2,
            label=label or None)
    if errors and fields.blocks > 1:
        err = _select(fields.errors(name), fields, component, "components")
        known = np.isfinite(err) & np.isfinite(y)
        ax.fill_between(x, y - err, y + err, where=known, color=colour, alpha=0.25, lw=0)


def plot_profiles(
    fields: CGFields | Sequence[CGFields],
    names: str | Sequence[str],
    path: str | Path,
    *,
    components: Component | Sequence[Component] = None,
    labels: Sequence[str] | None = None,
    errors: bool = True,
) -> Path:
    """Profiles of fields along the single resolved coordinate of 1D grids (slabs, r-profiles).

    One panel per field name; several ``CGFields`` (e.g. layers (a) and (b), on grids that
    resolve the same coordinate) are overlaid in each panel. With ``errors`` and more than one
    block a shaded band of +- one block standard error is drawn, skipped where it is NaN.

    Parameters
    ----------
    fields : one or several coarse-grained fields, each on a grid with one resolved coordinate.
    names : a field name or a sequence of names (:data:`~grainflow.analysis.cg.FIELDS`).
    path : output PNG path.
    components : for a single name its component (None, an index or an index pair); for a
        sequence of names None (all scalar fields) or one component per name.
    labels : one legend label per ``CGFields``; default none for one, "set i" for several.
    errors : draw the block error bands.
    """
    field_list = _as_list(fields)
    panels = _profile_components(names, components)
    coordinate = _profile_axis(field_list)
    default = [""] if len(field_list) == 1 else [f"set {i + 1}" for i in range(len(field_list))]
    legend = _labels(labels, len(field_list), default)
    colours = colormaps["tab10"].colors
    fig = new_figure(len(panels))
    axes = np.atleast_1d(fig.subplots(1, len(panels)))
    for ax, (name, component) in zip(axes, panels):
        for i, (f, label) in enumerate(zip(field_list, legend)):
            _draw_profile(ax, f, name, component, colour=colours[i % 10],
                          marker=_MARKERS[i % len(_MARKERS)], label=label, errors=errors)
        ax.set_xlabel(_axis_label(coordinate))
        ax.set_ylabel(_field_label(field_list[0], name, component))
        if any(legend):
            ax.legend(fontsize=7, frameon=False)
    return save_figure(fig, path)


# --- rheology: mu*(I), phi(I) ----------------------------------------------------------------

def _data(x_name: str, x: ArrayLike, y_name: str, y: ArrayLike, err_name: str,
          err: ArrayLike | None, *, log_x: bool) -> tuple[np.ndarray, np.ndarray,
                                                           np.ndarray | None]:
    """Validated 1-D (x, y, err); ValueError naming the offending argument."""
    xs = np.asarray(x, dtype=float)
    ys = np.asarray(y, dtype=float)
    if xs.ndim != 1 or xs.size == 0:
        raise ValueError(f"{x_name}: expected a non-empty 1-D array, got shape {xs.shape}")
    if ys.shape != xs.shape:
        raise ValueError(f"{y_name}: expected shape {xs.shape} like {x_name}, got {ys.shape}")
    if log_x and not np.any(xs > 0):
        raise ValueError(f"{x_name}: a log axis needs values > 0")
    if err is None:
        return xs, ys, None
    es = np.asarray(err, dtype=float)
    if es.shape != xs.shape:
        raise ValueError(f"{err_name}: expected shape {xs.shape} like {x_name}, got {es.shape}")
    return xs, ys, es


def _curve_x(x: np.ndarray, log: bool) -> np.ndarray:
    """Abscissae for fitted curves: the data's range; on a log axis its positive part,
    widened by a factor 1.5 each way."""
    if log:
        positive = x[np.isfinite(x) & (x > 0)]
        return np.geomspace(positive.min() / 1.5, positive.max() * 1.5, 300)
    finite = x[np.isfinite(x)]
    return np.linspace(finite.min(), finite.max(), 300)


def plot_mu_of_I(
    I: ArrayLike,
    mu: ArrayLike,
    path: str | Path,
    *,
    mu_err: ArrayLike | None = None,
    fits: MuFit | Sequence[MuFit] = (),
    labels: Sequence[str] | None = None,
    xlog: bool = True,
) -> Path:
    """Effective friction mu* against the inertial number with fitted laws (Figs. 5.7, 6.6).

    Parameters
    ----------
    I, mu : (M,) inertial numbers and effective friction coefficients.
    path : output PNG path.
    mu_err : (M,) standard errors of mu (error bars).
    fits : one or several results of :func:`~grainflow.analysis.rheology.fit_mu_of_I`,
        :func:`~grainflow.analysis.rheology.fit_mu_power_law` or
        :func:`~grainflow.analysis.rheology.fit_mu_linear`; each drawn with ``predict`` over
        the data's range, its parameters with errors in the legend.
    labels : one legend name per fit; default the fitted law.

    The mu axis is scaled to the data, so a curve extrapolated far off them leaves the frame.
    xlog : logarithmic I axis.
    """
    x, y, err = _data("I", I, "mu", mu, "mu_err", mu_err, log_x=xlog)
    fit_list = _as_list(fits)
    for fit in fit_list:
        if not isinstance(fit, (MuOfIFit, MuPowerLawFit, MuLinearFit)):
            raise ValueError(f"fits: expected MuOfIFit, MuPowerLawFit or MuLinearFit results, "
                             f"got {type(fit).__name__}")
    names = _labels(labels, len(fit_list), [_FIT_NAMES[type(f)] for f in fit_list])
    fig = new_figure(1, width=5.2, height=4.0)
    ax = fig.subplots()
    ax.errorbar(x, y, yerr=err, fmt="o", color="k", ms=4, capsize=2, mfc="none", label="data")
    data_limits = ax.get_ylim()
    curve = _curve_x(x, xlog)
    colours = colormaps["tab10"].colors
    for i, (fit, name) in enumerate(zip(fit_list, names)):
        ax.plot(curve, fit.predict(curve), "-", color=colours[i % 10], lw=1.3,
                label=f"{name}\n{fit_parameters_text(fit)}")
    ax.set_ylim(data_limits)
    if xlog:
        ax.set_xscale("log")
    ax.set_xlabel(r"inertial number $I$")
    ax.set_ylabel(r"effective friction $\mu^* = -\sigma_{ab}/P$")
    ax.legend(fontsize=7, frameon=False, loc="upper left")
    return save_figure(fig, path)


def plot_phi_of_I(
    I: ArrayLike,
    phi: ArrayLike,
    path: str | Path,
    *,
    phi_err: ArrayLike | None = None,
    fit: DivergenceFit | None = None,
    label: str = "I_s",
) -> Path:
    """Packing fraction against I on a log axis with the fit phi = phi_c - a I^(2/alpha)
    (eqs. 6.2/6.3, Figs. 6.3/6.4).

    Parameters
    ----------
    I, phi : (M,) inertial (or temperature) numbers, > 0, and packing fractions.
    path : output PNG path.
    phi_err : (M,) standard errors of phi (error bars).
    fit : a :func:`~grainflow.analysis.rheology.fit_divergence` result to draw, its
        parameters with errors in the legend.
    label : the number's symbol in TeX without dollars (``"I_s"``, ``"I_T"``).

    The phi axis is scaled to the data and phi_c (dotted), so the curve may leave the frame
    where it is extrapolated.
    """
    x, y, err = _data("I", I, "phi", phi, "phi_err", phi_err, log_x=True)
    if fit is not None and not isinstance(fit, DivergenceFit):
        raise ValueError(f"fit: expected a DivergenceFit, got {type(fit).__name__}")
    fig = new_figure(1, width=5.2, height=4.0)
    ax = fig.subplots()
    ax.errorbar(x, y, yerr=err, fmt="o", color="k", ms=4, capsize=2, mfc="none", label="data")
    if fit is not None:
        data_limits = ax.get_ylim()
        curve = _curve_x(x, True)
        ax.plot(curve, fit.predict(curve), "-", color="tab:red", lw=1.3,
                label=rf"$\phi_c - a\,{label}^{{2/\alpha}}$" f"\n{fit_parameters_text(fit)}")
        ax.axhline(fit.phi_c, ls=":", color="tab:red", lw=0.8)
        ax.set_ylim(min(data_limits[0], fit.phi_c), max(data_limits[1], fit.phi_c))
    ax.set_xscale("log")
    ax.set_xlabel(f"${label}$")
    ax.set_ylabel(r"packing fraction $\phi$")
    ax.legend(fontsize=7, frameon=False, loc="lower left")
    return save_figure(fig, path)


# --- velocity distributions ------------------------------------------------------------------

def plot_velocity_distributions(
    velocities: ArrayLike,
    path: str | Path,
    *,
    components: Sequence[str] = ("z", "r", "theta"),
    bins: int = 40,
) -> Path:
    """Scaled velocity distributions f~(c) per component on a log axis (Fig. 5.8).

    c = (v - <v>) / v0 with v0 the standard deviation
    (:func:`~grainflow.analysis.rheology.velocity_distribution`); the unit-variance Gaussian
    (flatness 3) and exponential (flatness 6) are drawn for reference, and each component's
    flatness <u^4>/<u^2>^2 is given in the legend.

    Parameters
    ----------
    velocities : (N, K) velocities of the grains in a cell, one column per component (or (N,)
        for one component).
    path : output PNG path.
    components : names of the K columns (``"theta"`` is written as a Greek letter).
    bins : number of equal bins over -5 < c < 5.
    """
    v = np.asarray(velocities, dtype=float)
    columns = v[:, None] if v.ndim == 1 else v
    names = list(components)
    if columns.ndim != 2 or columns.shape[1] != len(names):
        raise ValueError(f"components: expected one name per velocity column, got {len(names)} "
                         f"names for velocities of shape {v.shape}")
    dist = velocity_distribution(columns, bins)
    flat = np.atleast_1d(flatness(columns))
    fig = new_figure(1, width=5.0, height=4.0)
    ax = fig.subplots()
    colours = colormaps["tab10"].colors
    for k, name in enumerate(names):
        density = np.where(dist.density[:, k] > 0, dist.density[:, k], np.nan)
        ax.plot(dist.centres, density, _MARKERS[k % len(_MARKERS)], color=colours[k % 10],
                ms=4, mfc="none", label=rf"$c_{{{_tex(name)}}}$: flatness {flat[k]:.2f}")
    c = np.linspace(dist.centres[0], dist.centres[-1], 400)
    ax.plot(c, gaussian_vdf(c), "-", color="0.3", lw=1, label="Gaussian (flatness 3)")
    ax.plot(c, exponential_vdf(c), "--", color="0.3", lw=1, label="exponential (flatness 6)")
    ax.set_yscale("log")
    ax.set_xlabel(r"$c_a = (v_a - \langle v_a \rangle)/v_{a0}$")
    ax.set_ylabel(r"$\tilde f(c_a)$")
    ax.legend(fontsize=7, frameon=False, loc="lower center")
    return save_figure(fig, path)
