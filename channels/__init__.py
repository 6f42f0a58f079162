"""Propagation for rfsim: antennas, large-scale loss, exponential-APDP small scale,
surfaces (virtual transmitters), walls/shadowing, noise and link assembly.

A channel yields, per link, a :class:`PathSet` (complex amplitude gains and delays in
float64 seconds, plus Doppler shifts); applying it to a waveform is a separate step
(:func:`apply_paths`) with the exact carrier phase exp(−j2π·fc·τ).

Modules: :mod:`~rfsim.channels.geometry` (orientations, directions), :mod:`~rfsim.channels.antennas`
(patterns, polarization), :mod:`~rfsim.channels.large_scale` (Friis/log-distance, walls,
shadowing), :mod:`~rfsim.channels.small_scale` (exponential APDP taps, a Rician gain process in time), :mod:`~rfsim.channels.surfaces`
(Fresnel, image method), :mod:`~rfsim.channels.noise` (AWGN), :mod:`~rfsim.channels.paths` (path sets
and their application), :mod:`~rfsim.channels.scene` (assembly of links in a scene).
"""

from rfsim.core.lazy import lazy_exports

#: Module of the package → the public names it provides, each imported on first use (so
#: that importing one module, e.g. for a config dataclass, does not import the others).
_SOURCES = {
    "antennas": ("Antenna", "EllipticalPanel", "HalfWaveDipole", "Isotropic", "Patch", "Tabulated", "vertical_dipole"),
    "bulk": ("BulkPaths", "draw_links"),
    "geometry": ("Pose", "direction_to", "rotation_matrix"),
    "large_scale": ("LogDistance", "ShadowingField", "Wall", "friis_amplitude_gain", "wall_loss_db",
                    "LinkLargeScale"),
    "noise": ("complex_awgn", "noise_power_from_density_w", "thermal_noise_power_w"),
    "paths": ("PathSet", "apply_backscatter", "apply_paths", "compose_backscatter", "concatenate",
              "narrowband_error_bound", "narrowband_rms_error", "propagation_method",
              "NARROWBAND_TOLERANCE", "PROPAGATION_METHODS"),
    "scene": ("Channel", "HeldLinks", "Scene", "kinematics", "los_links"),
    "small_scale": ("ApdpModel", "average_profile", "draw_taps", "profile_statistics", "rician_gains"),
    "surfaces": ("Surface", "fresnel_reflection", "fresnel_transmission", "image_paths"),
}
__getattr__, __dir__ = lazy_exports(globals(), _SOURCES)

__all__ = [
    "Antenna", "EllipticalPanel", "Isotropic", "HalfWaveDipole", "Patch", "Tabulated", "vertical_dipole",
    "Pose", "direction_to", "rotation_matrix",
    "LogDistance", "ShadowingField", "Wall", "friis_amplitude_gain", "wall_loss_db",
    "LinkLargeScale",
    "complex_awgn", "noise_power_from_density_w", "thermal_noise_power_w",
    "PathSet", "apply_paths", "apply_backscatter", "compose_backscatter", "concatenate",
    "narrowband_error_bound", "narrowband_rms_error", "propagation_method", "NARROWBAND_TOLERANCE",
    "PROPAGATION_METHODS",
    "Scene", "Channel", "HeldLinks", "los_links", "kinematics", "draw_links", "BulkPaths",
    "ApdpModel", "average_profile", "draw_taps", "profile_statistics", "rician_gains",
    "Surface", "fresnel_reflection", "fresnel_transmission", "image_paths",
]
