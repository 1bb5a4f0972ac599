"""Reader and writer of LAMMPS data files with ``atom_style sphere`` (re-exported).

They live in :mod:`grainflow.insertion.lammps_data` (reading particles from a data
file is a kind of fill, and scenarios below ``grainflow.io`` use it); this module keeps the
old import path working.
"""

from grainflow.insertion.lammps_data import (LammpsData, read_lammps_data,
                                             state_from_lammps_data, write_lammps_data)

__all__ = ["LammpsData", "read_lammps_data", "state_from_lammps_data", "write_lammps_data"]
