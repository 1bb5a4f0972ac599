"""Analyses of cohesive granular streams falling from a hopper aperture (SPEC S1, A5-A7), after
seed 000: S. R. Waitukaitis et al., "Droplet and cluster formation in freely falling granular
streams", PRE 83, 051302 (2011), arXiv 1006.1371.

Pure functions of saved frames (:class:`~grainflow.frame.Frame`, e.g. from
:func:`grainflow.io.h5md.read_frames`) or of arrays. Conventions (those of the ``stream``
scenario, :mod:`grainflow.scenarios.stream`): SI units; gravity along -z; the aperture (a hole
of diameter D in the hopper's flat base) is centred on the origin and the base's top surface is
the plane z = 0; the *depth* below the aperture is -z (positive downward, negative inside the
hopper); grains are monodisperse spheres of type 0; walls are analytic (no wall particles).

* :mod:`~grainflow.analysis.stream.networks` (A5): contact pairs (surface gap < delta),
  contact number Z, networks and network size N, their depth profiles, Z / Z_0, N_inf.
* :mod:`~grainflow.analysis.stream.fluctuations` (A6): per-grain velocity deviations relative
  to neighbours within 1.5 d, axial and transverse, their profiles, the free-fall model
  <dv_z^2> = (g dz)^2 / (v0^2 + 2 g z) and its one-parameter fit, the speed v0 at the aperture.
* :mod:`~grainflow.analysis.stream.droplets` (A7): droplets (networks of >= 30 grains), their
  principal-axis length, width and aspect ratio, the seed's selection, the aspect-ratio
  histogram, tracking by shared ids, separation velocities of adjacent droplets and the
  free-fall prediction sqrt(v0^2 + 2 g dz0) - v0.
* :mod:`~grainflow.analysis.stream.traced_pairs` (A7, the seed's method): adjacent droplets
  followed back by their grains' ids to the aperture, their spacing there and initial and
  final separation velocities, and the free-fall fit whose gradient g d / V is the seed's
  1.4 cm/s.
* :mod:`~grainflow.analysis.stream.toy_model` (seed 000, Sec. IV): the droplet length scale
  at the aperture, L0, from the tracked separations, and the fit L0 = (F_c / Sigma)^(1/2).
* :mod:`~grainflow.analysis.stream.regimes` (A7): spray / clustering / droplets / dripping from
  the network-size profile, droplet presence and the outflow steadiness.

Depth profiles are :class:`DepthProfile` objects: per-grain values pooled over frames in bins
aligned on the aperture plane, with frame-to-frame standard errors.
"""

from grainflow.analysis.stream._common import (GRAVITY, DepthProfile, ProfileValue,
                                               depth_profile, profile_value_at, stream_grains)
from grainflow.analysis.stream.droplets import (DEFAULT_AZIMUTH_BINS, SEED_EXCLUDE_FARTHEST,
                                                SEED_MIN_DEPTH, SEED_MIN_GRAINS,
                                                AspectHistogram, Droplet, DropletSelection,
                                                DropletSeparation, DropletShape, DropletTrack,
                                                aspect_ratio_histogram, droplet_separations,
                                                droplet_shape, find_droplets,
                                                free_fall_separation_velocity, select_droplets,
                                                track_droplets)
from grainflow.analysis.stream.fluctuations import (SEED_DEVIATION_BIN, SEED_MIN_NEIGHBOURS,
                                                    SEED_NEIGHBOUR_FACTOR, ApertureSpeed,
                                                    DeviationProfiles, FreeFallFit,
                                                    VelocityDeviations, aperture_speed,
                                                    fit_free_fall_deviation,
                                                    fit_free_fall_profile,
                                                    frame_velocity_deviations,
                                                    free_fall_axial_deviation, free_fall_speed,
                                                    SuperficialSpeed, superficial_speed,
                                                    velocity_deviation_profile,
                                                    velocity_deviations)
from grainflow.analysis.stream.networks import (SEED_CONTACT_BIN, SEED_NETWORK_BIN,
                                                SEED_SATURATION_DEPTH, ContactProfiles,
                                                Networks, NormalisedProfile, contact_numbers,
                                                contact_pairs, contact_profiles, find_networks,
                                                frame_networks, network_labels, network_sizes,
                                                normalised_contact_number,
                                                saturation_network_size)
from grainflow.analysis.stream.regimes import (REGIMES, OutflowSteadiness, RegimeDecision,
                                               RegimeThresholds, classify_regime,
                                               outflow_steadiness)
from grainflow.analysis.stream.traced_pairs import (SeparationGradient, TracedPair,
                                                    fit_separation_gradient, trace_droplet_pairs)
from grainflow.analysis.stream.toy_model import (ApertureLength, ToyModelFit, aperture_length,
                                                 fit_toy_model, gradient_kinetic_energy)

__all__ = [
    # common
    "GRAVITY", "DepthProfile", "ProfileValue", "depth_profile", "profile_value_at",
    "stream_grains",
    # A5 networks
    "SEED_CONTACT_BIN", "SEED_NETWORK_BIN", "SEED_SATURATION_DEPTH",
    "contact_pairs", "contact_numbers", "network_labels", "network_sizes",
    "Networks", "find_networks", "frame_networks", "ContactProfiles", "contact_profiles",
    "NormalisedProfile", "normalised_contact_number", "saturation_network_size",
    # A6 fluctuations
    "SEED_NEIGHBOUR_FACTOR", "SEED_MIN_NEIGHBOURS", "SEED_DEVIATION_BIN",
    "VelocityDeviations", "velocity_deviations", "frame_velocity_deviations",
    "DeviationProfiles", "velocity_deviation_profile", "free_fall_speed",
    "free_fall_axial_deviation", "FreeFallFit", "fit_free_fall_deviation",
    "fit_free_fall_profile", "ApertureSpeed", "aperture_speed", "SuperficialSpeed",
    "superficial_speed",
    # A7 droplets
    "SEED_MIN_GRAINS", "SEED_MIN_DEPTH", "SEED_EXCLUDE_FARTHEST", "DEFAULT_AZIMUTH_BINS",
    "DropletShape", "droplet_shape", "Droplet", "find_droplets", "DropletSelection",
    "select_droplets", "AspectHistogram", "aspect_ratio_histogram", "DropletTrack",
    "track_droplets", "DropletSeparation", "droplet_separations",
    "free_fall_separation_velocity", "TracedPair", "trace_droplet_pairs",
    "SeparationGradient", "fit_separation_gradient",
    # toy model
    "ApertureLength", "aperture_length", "ToyModelFit", "fit_toy_model",
    "gradient_kinetic_energy",
    # A7 regimes
    "REGIMES", "RegimeThresholds", "RegimeDecision", "classify_regime",
    "OutflowSteadiness", "outflow_steadiness",
]
