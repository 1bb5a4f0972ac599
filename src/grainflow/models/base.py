"""The contact-law interface: a compiled evaluator plus a per-type-pair parameter table.

A law is declared once as a subclass of :class:`ContactLaw`:

* ``param_names``: the columns of its parameter table ``table[type_i, type_j, :]``;
* ``history_size`` / ``history_flip``: how many numbers each pair remembers between steps
  and which of them change sign when the roles of i and j swap;
* ``evaluator``: a numba-compiled function with the signature documented in
  :mod:`grainflow.kernels.pair_loop`, used for particle pairs *and* particle-wall contacts.

The shared pair loop and wall loop are written once; each law is written once. Adding a law
never touches the engine.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, ClassVar

import numpy as np


class ContactLaw(ABC):
    """Base class of contact laws with per-type-pair parameters."""

    name: ClassVar[str]
    param_names: ClassVar[tuple[str, ...]]
    history_size: ClassVar[int]
    history_flip: ClassVar[tuple[float, ...]]

    def __init__(self, n_types: int = 1) -> None:
        if n_types < 1:
            raise ValueError("n_types: must be >= 1")
        self.table = np.zeros((n_types, n_types, len(self.param_names)))
        self._set_types: set[tuple[int, int]] = set()

    @property
    def n_types(self) -> int:
        return int(self.table.shape[0])

    @property
    @abstractmethod
    def evaluator(self) -> Any:
        """The compiled pair evaluator."""

    def set_pair(self, type_i: int, type_j: int, **params: float) -> None:
        """Set the parameters of one (symmetric) type pair; unspecified ones keep defaults."""
        if not (0 <= type_i < self.n_types and 0 <= type_j < self.n_types):
            self._grow(max(type_i, type_j) + 1)
        row = self._row(**params)
        self.table[type_i, type_j] = row
        self.table[type_j, type_i] = row
        self._set_types.add((min(type_i, type_j), max(type_i, type_j)))

    def set_all(self, **params: float) -> None:
        """Set the same parameters for every type pair."""
        row = self._row(**params)
        self.table[:, :] = row
        for a in range(self.n_types):
            for b in range(a, self.n_types):
                self._set_types.add((a, b))

    def ensure_types(self, n_types: int) -> None:
        """Grow the table to ``n_types``; new pairs copy the (0, 0) parameters."""
        if n_types > self.n_types:
            self._grow(n_types)

    def _grow(self, n: int) -> None:
        old = self.table
        self.table = np.broadcast_to(old[0, 0], (n, n, old.shape[2])).copy()
        self.table[: old.shape[0], : old.shape[1]] = old

    @abstractmethod
    def _row(self, **params: float) -> np.ndarray:
        """Validate user parameters and build one table row."""

    def reach(self) -> float:
        """How far beyond touching (surface gap) the law acts; 0 for pure contact laws.

        Contract with the pair loop: beyond ``r_i + r_j + reach`` the law exerts no force and
        its history for the pair is zero (the loop does not call the evaluator there).
        """
        return 0.0

    @abstractmethod
    def contact_time(self, type_i: int, type_j: int, meff: float, sigma: float) -> float:
        """Duration of a binary collision of a type pair with effective mass ``meff`` and
        contact distance ``sigma`` (for the time-step check)."""

    @property
    def flip(self) -> np.ndarray:
        return np.asarray(self.history_flip, dtype=np.float64)


def require(value: float, name: str, condition: bool, valid: str) -> float:
    """Raise ValueError naming the parameter, its value and what would be valid."""
    if not condition or not np.isfinite(value):
        raise ValueError(f"{name}: {value!r} is not valid; expected {valid}")
    return float(value)
