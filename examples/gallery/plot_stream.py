"""# A cohesive granular stream (seed 000)

Seed 000 (Waitukaitis et al., PRE 83, 051302 (2011)) lets glass grains (d = 200 um) flow out
of a hopper through a circular aperture and fall freely. With a weak cohesion (a constant
force F_c within a shell delta ~ 100 nm of contact, hysteretic: it acts only after a first
touch) the falling stream does not thin out into a spray but gathers into clusters and
droplets. This example runs the `stream` scenario in a tiny hopper (about 600 grains, a
1.4 mm aperture, the stream followed to 2 cm) with restitution 0.40 and F_c = 1000 nN,
about ten times a grain's weight, and measures with `grainflow.analysis.stream` the mean
contact number Z and the network size N (the number of grains linked by contacts) against
the depth below the aperture.

The figure shows Z / Z_0 and N against depth (the contact number rises as the stream
falls: colliding grains stick and clusters grow), and a side view of the stream with each
grain coloured by the size of its network.

Shortened: a hopper of 2.4 mm with soft contacts (t_c = 200 us), 2 cm of stream and 40 ms
of steady flow. The study (`grainflow study stream -o stream_study`, reduced: 9 runs of
8,400 grains followed to 6 cm, about 33 minutes on 2 cores) maps the regimes over (e, F_c);
see docs/streams.md.
"""

# %%
# The run
# -------
# SI units, written with their units (`"200 um"`); the scenario converts them. The aperture
# opens at 30 ms, after the bed settled; the stream's front reaches 2 cm at about 100 ms, so
# frames are kept from then on, one every millisecond.

from pathlib import Path

import grainflow as gf
from grainflow.analysis.stream import (contact_profiles, normalised_contact_number,
                                       profile_value_at)
from grainflow.io import read_frames
from grainflow.plotting.stream_plots import (plot_contact_number, plot_network_size,
                                             plot_stream_side)

DELTA = 100e-9  # the cohesive shell, metres
stream = dict(grain_diameter="200 um", aperture_diameter="1.4 mm", hopper_diameter="2.4 mm",
              fill_height="1.0 mm", contact_time="200 us", open_time="0.03 s",
              stream_depth="2 cm", stream_radius="1 cm", restitution=0.40,
              cohesion_force="1000 nN", cohesion_range="100 nm")
config = {"scenario": "stream", "dim": 3, "run": {"duration": "0.14 s", "seed": 3},
          "output": {"thermo_every": 5000, "frames_every": 250, "frames_from": "0.1 s",
                     "checkpoint_every": 0, "snapshot": False},
          "stream": stream}
summary = gf.run_config(config, "runs/stream", overwrite=True, progress="none")
frames = list(read_frames("runs/stream/frames.h5"))
print(f"{summary.steps} steps in {summary.wall_time_s:.0f} s; {len(frames)} frames of "
      f"{frames[0].n}-{max(f.n for f in frames)} grains")

# %%
# Contact numbers and networks against depth
# ------------------------------------------
# Two grains are in contact when their surfaces are closer than delta (they feel the
# cohesion). `contact_profiles` pools every grain of every frame into depth bins (1 mm for
# Z, 5 mm for N, the seed's) with frame-to-frame error bars; Z_0 is Z in the first
# millimetre below the aperture. The bed in the hopper (depth < 0) and the grains past
# 2 cm, about to be deleted, are left out.

profiles = contact_profiles(frames, DELTA, depth_range=(0.0, 0.02))  # the stream only
z_norm = normalised_contact_number(profiles)
z0 = z_norm.reference
deep = profile_value_at(profiles.contact_number, 0.0185)
n_deep = profile_value_at(profiles.network_size, 0.0175)
print(f"Z_0 = {z0.value:.2f} +/- {z0.err:.2f}; Z at 1.85 cm = {deep.value:.2f} +/- "
      f"{deep.err:.2f}; network size at 1.5-2 cm N = {n_deep.value:.0f} +/- {n_deep.err:.0f}")
assert deep.value > z0.value, "a cohesive stream should gain contacts as it falls"

plot_contact_number(z_norm, Path("stream_contact_number.png"),
                    labels=[f"e = 0.40, F_c = 1000 nN (Z_0 = {z0.value:.2f})"])
plot_network_size(profiles, Path("stream_network_size.png"),
                  labels=["e = 0.40, F_c = 1000 nN"])

# %%
# A side view
# -----------
# The last frame, the first 2 cm below the aperture in two strips side by side, each grain
# coloured by the size of the network it belongs to (the hopper's bed, above the aperture,
# is not drawn; grains leaving through the aperture still belong to the bed's network,
# hence the bright top).

plot_stream_side(frames[-1], Path("stream_side.png"), DELTA, depth_range=(0.0, 0.02),
                 columns=2)
