"""Propagation for rfsim: antennas, large-scale loss, exponential-APDP small scale,
surfaces (virtual transmitters), walls/shadowing, noise and link assembly.

A channel yields, per link, a :class:`PathSet` (complex amplitude gains and delays in
float64 seconds, plus Doppler shifts); applying it to a waveform is a separate step
(:func:`apply_paths`) with the exact carrier phase exp(−j2π·fc·τ).

Modules: :mod:`~channels.geometry` (orientations, directions), :mod:`~channels.antennas`
(patterns, polarization), :mod:`~channels.large_scale` (Friis/log-distance, walls,
shadowing), :mod:`~channels.small_scale` (exponential APDP taps), :mod:`~channels.surfaces`
(Fresnel, image method), :mod:`~channels.noise` (AWGN), :mod:`~channels.paths` (path sets
and their application), :mod:`~channels.scene` (assembly of links in a scene).
"""

from channels.antennas import Antenna, HalfWaveDipole, Isotropic, Patch, Tabulated, vertical_dipole
from channels.bulk import BulkPaths, draw_links
from channels.geometry import Pose, direction_to, rotation_matrix
from channels.large_scale import (LogDistance, ShadowingField, Wall, friis_amplitude_gain,
                                  wall_loss_db)
from channels.large_scale import LinkLargeScale
from channels.noise import complex_awgn, noise_power_from_density_w, thermal_noise_power_w
from channels.paths import (PathSet, apply_backscatter, apply_paths, compose_backscatter,
                            concatenate, narrowband_error_bound, narrowband_rms_error,
                            propagation_method, NARROWBAND_TOLERANCE, PROPAGATION_METHODS)
from channels.scene import Channel, HeldLinks, Scene, kinematics, los_links
from channels.small_scale import ApdpModel, average_profile, draw_taps, profile_statistics
from channels.surfaces import Surface, fresnel_reflection, fresnel_transmission, image_paths

__all__ = [
    "Antenna", "Isotropic", "HalfWaveDipole", "Patch", "Tabulated", "vertical_dipole",
    "Pose", "direction_to", "rotation_matrix",
    "LogDistance", "ShadowingField", "Wall", "friis_amplitude_gain", "wall_loss_db",
    "LinkLargeScale",
    "complex_awgn", "noise_power_from_density_w", "thermal_noise_power_w",
    "PathSet", "apply_paths", "apply_backscatter", "compose_backscatter", "concatenate",
    "narrowband_error_bound", "narrowband_rms_error", "propagation_method", "NARROWBAND_TOLERANCE",
    "PROPAGATION_METHODS",
    "Scene", "Channel", "HeldLinks", "los_links", "kinematics", "draw_links", "BulkPaths",
    "ApdpModel", "average_profile", "draw_taps", "profile_statistics",
    "Surface", "fresnel_reflection", "fresnel_transmission", "image_paths",
]
