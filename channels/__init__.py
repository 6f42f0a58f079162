"""Propagation for rfsim: antennas, large-scale loss, exponential-APDP small scale,
surfaces (virtual transmitters), walls/shadowing, noise and link assembly."""
