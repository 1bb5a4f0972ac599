"""Reproductions of the seed papers' studies: sweeps, fits and a report per study."""
