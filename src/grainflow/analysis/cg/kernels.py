"""Coarse-graining kernels: how much of a grain (or of a point of a branch line) a cell sees.

* :class:`Heaviside`: bins. A grain belongs wholly to the cell holding its centre; a branch
  line gives each cell the fraction of its length inside it (seed 002 Appendix C, eq. C.29).
  Fields are cell averages (sums divided by the cell's volume).
* :class:`Gaussian`: ``W(r) = (2 pi w^2)^(-k/2) exp(-r^2 / 2 w^2) / P(k/2, c^2/2)`` for
  ``r <= c w``, zero beyond, with ``P`` the regularised lower incomplete gamma function (the
  weight of a k-dimensional Gaussian inside radius ``c w``), so that it integrates to one.
* :class:`Lucy`: ``W(r) = A_k (1 + 3 r/c)(1 - r/c)^3`` for ``r <= c`` (Lucy 1977, the
  default kernel of MercuryCG), ``A_1 = 5/(4c)``, ``A_2 = 5/(pi c^2)``,
  ``A_3 = 105/(16 pi c^3)``.

Smooth kernels act in the k coordinates a grid resolves (Weinhart et al., Granular Matter 14,
289 (2012): the fields are point values ``sum_i q_i W(r - r_i)``); along averaged directions
every kernel is a Heaviside over the averaged extent. Branch lines are integrated with
Gauss-Legendre quadrature (``line_points`` per line). The quadrature error is set by the
kernel's smoothness at its edge: Lucy's kernel is twice differentiable there (errors ~1e-4 of
the peak with its default 8 points, ~1e-5 with 12); the cut Gaussian jumps there by
``exp(-cutoff^2 / 2)`` of its peak, which bounds what more points can gain: with the default
cutoff of 4 widths (jump 3e-4) the error is ~1e-4 with its default 4 points and ~4e-5 with 8;
tests/test_cg.py measures both against a brute-force line integral.
Gradients of fields (the strain rate, a divergence) taken by finite differences on a grid finer
than the width see that jump as noise growing like 1/spacing: for them use Lucy, or a Gaussian
cut at 5 widths or more (tests/test_cg_validation.py measures the settled column's balance so).
"""

from __future__ import annotations

from dataclasses import dataclass
from math import gamma, pi

from scipy.special import gammainc

from grainflow.kernels import cg_deposit

__all__ = ["Gaussian", "Heaviside", "Kernel", "Lucy"]


def _positive(name: str, value: float) -> float:
    value = float(value)
    if not value > 0 or value == float("inf"):
        raise ValueError(f"{name}: must be a positive finite number, got {value!r}")
    return value


@dataclass(frozen=True)
class Heaviside:
    """Bins: cell averages, exact branch-line fractions (seed 002 eqs. C.31-C.33)."""

    smooth = False


@dataclass(frozen=True)
class Gaussian:
    """Gaussian of standard deviation ``width`` cut at ``cutoff`` widths and renormalised."""

    width: float
    cutoff: float = 4.0
    line_points: int = 4
    smooth = True
    code = cg_deposit.GAUSSIAN

    def __post_init__(self) -> None:
        _positive("width", self.width)
        if not 1.0 <= float(self.cutoff) < float("inf"):
            raise ValueError(f"cutoff: a finite number of widths >= 1, got {self.cutoff!r}")
        _check_line_points(self.line_points)

    @property
    def reach(self) -> float:
        """Distance beyond which the kernel is zero."""
        return self.cutoff * self.width

    def norm(self, k: int) -> float:
        """Prefactor making the k-dimensional kernel integrate to one."""
        return (2.0 * pi * self.width**2) ** (-k / 2) / gammainc(k / 2, self.cutoff**2 / 2)


@dataclass(frozen=True)
class Lucy:
    """Lucy's polynomial kernel of support radius ``cutoff``."""

    cutoff: float
    line_points: int = 8
    smooth = True
    code = cg_deposit.LUCY

    def __post_init__(self) -> None:
        _positive("cutoff", self.cutoff)
        _check_line_points(self.line_points)

    @property
    def width(self) -> float:
        """Passed to the compiled kernel (unused by Lucy's formula)."""
        return self.cutoff

    @property
    def reach(self) -> float:
        return self.cutoff

    def norm(self, k: int) -> float:
        # A_k = 1 / (c^k * S_k * int_0^1 s^(k-1) (1+3s)(1-s)^3 ds), S_k the unit sphere's
        # surface (2, 2 pi, 4 pi); the integrals are 2/5, 1/10, 4/105.
        moment = {1: 2 / 5, 2: 1 / 10, 3: 4 / 105}[k]
        surface = 2 * pi ** (k / 2) / gamma(k / 2)
        return 1.0 / (self.cutoff**k * surface * moment)


def _check_line_points(n: int) -> None:
    if not isinstance(n, int) or n < 1:
        raise ValueError(f"line_points: a positive integer (Gauss-Legendre points per branch "
                         f"line), got {n!r}")


Kernel = Heaviside | Gaussian | Lucy
