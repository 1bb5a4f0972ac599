"""Outputs that open outside grainflow: H5MD trajectories (HDF5), LAMMPS dumps (OVITO), VTK (ParaView).

The on-disk layouts are described in ``docs/output_format.md``.
"""

from grainflow.io.h5md import TrajectoryWriter, count_frames, read_frame, read_frames
from grainflow.io.lammps_data import LammpsData, read_lammps_data, state_from_lammps_data
from grainflow.io.lammps_dump import DumpFrame, read_lammps_dump, write_lammps_dump
from grainflow.io.vtk import VtkSeries, write_pvd, write_vtp

__all__ = [
    "DumpFrame",
    "LammpsData",
    "TrajectoryWriter",
    "VtkSeries",
    "count_frames",
    "read_frame",
    "read_frames",
    "read_lammps_data",
    "read_lammps_dump",
    "state_from_lammps_data",
    "write_lammps_dump",
    "write_pvd",
    "write_vtp",
]
