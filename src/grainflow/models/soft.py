"""The ``soft`` law (SPEC M3; seed 003, "SP" model): harmonic repulsion and kinetic friction.

:class:`SoftLaw` is the preset ``harmonic`` normal force (:mod:`grainflow.models.
normal_harmonic`, seed 003 eq. 4) + ``kinetic`` friction (:mod:`grainflow.models.
damping_kinetic`, seed 003 eq. 6). The viscous drag ``-zeta v`` of the background fluid is a
one-body force (:class:`grainflow.engine.forces.Drag`). No torques: SP particles do not
rotate.
"""

from __future__ import annotations

from grainflow.models.base import ContactLaw

__all__ = ["SoftLaw"]


class SoftLaw(ContactLaw):
    """Soft harmonic particles with kinetic friction (M3).

    Parameters per type pair: ``epsilon`` (energy scale of the harmonic repulsion),
    ``mu_k`` (kinetic-friction coefficient, force per unit relative velocity) and
    ``kinetic_on`` (``"full"`` relative velocity, seed 003 eq. 6, or ``"tangential"``).
    """

    def __init__(self, n_types: int = 1) -> None:
        super().__init__(n_types, law="soft")
