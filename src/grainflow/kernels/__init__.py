"""grainflow.kernels: the numba kernels.

Importing this package chooses numba's threading layer for the whole process, unless the
user chose one (``NUMBA_THREADING_LAYER`` or ``NUMBA_THREADING_LAYER_PRIORITY`` in the
environment): OpenMP first, then TBB, then numba's own workqueue. numba's default order puts
TBB first whenever libtbb is installed (Debian's ``lammps`` package brings it), and TBB ran the
1600-grain demo hopper 12 times slower on 2 threads than on 1 (issue 11); the workqueue layer
runs it at 971 steps/s on 2 threads against 9,100 with OpenMP (Intel Xeon, 2 cores). The
layer is fixed at numba's first parallel launch, so this must run before any kernel does.
"""

import os

import numba

#: numba's threading layers, best first, as measured on the demo hopper and the chute.
LAYER_PRIORITY = ["omp", "tbb", "workqueue"]

if not {"NUMBA_THREADING_LAYER", "NUMBA_THREADING_LAYER_PRIORITY"} & set(os.environ):
    numba.config.THREADING_LAYER_PRIORITY = LAYER_PRIORITY
