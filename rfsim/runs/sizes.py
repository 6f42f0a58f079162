"""Size models of the built-in scenarios (:class:`~rfsim.runs.resources.Estimate` of a config).

A model reads only the config's keys (the core never imports the scenarios). Its peak is the
scenario's baseline (the peak resident memory of its smallest run, kernels cached, rounded up)
plus bytes per work unit times the units held at once (the rows every unit adds to the tables
the run keeps until it writes them, and the unit's working arrays), both measured on runs of
two sizes and rounded up; a run with worker processes counts one process per worker besides
the leader (each holding the same baseline). ``tests/test_resources.py`` checks that the
estimate bounds the measured peak within 2x at two sizes of every scenario.

A first run compiles the scenario's numba kernels; what compiling adds to a process's peak is
:data:`COMPILE_MIB` (the estimate's ``compile_bytes``), measured as the peak of the smallest
run compiling in its own process on an empty kernel cache minus its peak on a full one, rounded
up (an upper bound for the short-lived compiling children runs use now,
:attr:`~rfsim.runs.resources.Estimate.first_run_bytes`); the test checks the bound on an empty
cache.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable

from rfsim.runs.resources import Estimate, pool_processes, process_peak

KiB, MiB = 2**10, 2**20


def estimate_of(module, config) -> Estimate | None:
    """The size of a run of a scenario.

    Parameters
    ----------
    module : module
        The scenario's module.
    config : dataclass
        Its resolved config.

    Returns
    -------
    Estimate or None
        The scenario's own ``resource_estimate(config)``, else the size model of its name
        (built-in scenario modules only, :data:`SIZE_MODELS`, with the compilation term of
        :data:`COMPILE_MIB`), else None (no check).
    """
    fn = getattr(module, "resource_estimate", None)
    if fn is None and getattr(module, "__name__", "").startswith("rfsim.scenarios."):
        model = SIZE_MODELS.get(module.NAME)
        if model is not None:
            return dataclasses.replace(model(config), compile_bytes=int(COMPILE_MIB[module.NAME] * MiB))
    return fn(config) if fn is not None else None


def _model(units: float, drivers: tuple[str, ...], *, base_mib: float, bytes_per_unit: float,
           workers: int = 1, tasks: int = 1, held: float | None = None) -> Estimate:
    """``units`` work units, ``held`` of them (default all) of ``bytes_per_unit`` above
    ``base_mib`` per process; one process per started pool worker (``workers`` for ``tasks``
    tasks) besides the leader."""
    peak = process_peak(bytes_per_unit, units if held is None else held, processes=pool_processes(workers, tasks),
                        baseline_bytes=int(base_mib * MiB))
    return Estimate(int(units), peak, drivers)


def _cells(config, cells_key: str, cells: int) -> Estimate:
    """phase-cancellation and st-to-st: cells × positions × repetitions sample rows."""
    mc = config.mc
    return _model(cells * mc.n_positions * mc.n_repetitions,
                  ("mc.positions_per_cell", "mc.repetitions", "mc.full", cells_key, "mc.workers"),
                  base_mib=260, bytes_per_unit=16 * KiB, workers=mc.workers, tasks=cells * mc.n_repetitions)


def _access(c) -> Estimate:
    """Trials (one per round and distance point, a round of every point in one batch) and their
    rows; each point's reader keeps its last 64 command segments (the Write's is 20 ms of CW), full
    after about 10 rounds (3.5 MiB a trial until then). Measured: 212 MiB at 1 round of 12 points,
    556 at 15, 610 at 40."""
    points = len(c.geometry.distances_m)
    return _model(c.rounds_per_point * points, ("rounds_per_point", "geometry.distances_m"),
                  base_mib=220 + 3.5 * min(c.rounds_per_point, 10) * points, bytes_per_unit=200 * KiB)


def _detection_probability(c) -> Estimate:
    """A block of ≤ 256 samples simulated at once (256 KiB each) and every sample's rows (20 KiB:
    243 -> 274 MiB measured from 1000 to 3000 samples, 15.9 KiB a sample)."""
    block = min(c.samples.count, 256) * 256 * KiB
    return _model(c.samples.count, ("samples.count", "samples.workers"), base_mib=290 + block / MiB,
                  bytes_per_unit=20 * KiB, workers=c.samples.workers, tasks=math.ceil(c.samples.count / 256))


def _exciter_link(c) -> Estimate:
    s = c.sweep
    units = (100 if s.full else s.draws_per_point) * len(s.exciter_distance_m) * len(s.tag_distance_m)
    return _model(units, ("sweep.draws_per_point", "sweep.full", "sweep.exciter_distance_m", "sweep.tag_distance_m",
                          "sweep.workers"), base_mib=290, bytes_per_unit=16 * KiB, workers=s.workers, tasks=units)


def _gen2_waveforms(c) -> Estimate:
    """Samples of the four exchanges (20.9 ms of signal in all) at ``fs_hz``."""
    return _model(math.ceil(c.fs_hz * 0.021), ("fs_hz",), base_mib=170, bytes_per_unit=64)


def _himr(c) -> Estimate:
    """Per millisecond of the run: the packets' sample-level records and the tracker's rows."""
    return _model(math.ceil(c.scene.duration_s * 1000), ("scene.duration_s",), base_mib=280,
                  bytes_per_unit=12 * KiB)


def _inventory(c) -> Estimate:
    units = (sum(c.populations) * c.runs + c.capture.trials * len(c.capture.ratios_db)
             + c.capture_sweep.trials * len(c.capture_sweep.ratios_db)
             + sum(c.capture_inventory.populations) * c.capture_inventory.runs * c.capture_inventory.enabled)
    return _model(units, ("populations", "runs", "capture.trials", "capture_sweep.trials", "capture_inventory.runs"),
                  base_mib=300, bytes_per_unit=4 * KiB)


def _link(c) -> Estimate:
    """One round of every distance point at once (one batch) and every round's rows; the peak
    levels off at 263 MiB from 120 rounds per point on (177 MiB at 10, 225 at 40, 263 at 240)."""
    return _model(c.rounds_per_point * len(c.geometry.distances_m), ("rounds_per_point", "geometry.distances_m"),
                  base_mib=280, bytes_per_unit=4 * KiB)


def _phase_tracking(c) -> Estimate:
    """Read rounds; every round's rows (3.2 KiB a round measured: 199 -> 247 MiB from 20 to 60 s
    at 400 rounds/s, which a 64 KiB-per-second model left 1.2 MiB a second short of)."""
    rounds = math.ceil(c.trajectory.duration_s / c.schedule.read_period_s)
    return _model(rounds, ("trajectory.duration_s", "schedule.read_period_s", "schedule.workers"), base_mib=300,
                  bytes_per_unit=4 * KiB, workers=c.schedule.workers, tasks=math.ceil(c.trajectory.duration_s / 10))


def _reader_detection(c) -> Estimate:
    """Queries in all; one row per trial (the queries of a trial are reduced in blocks)."""
    k = c.campaign
    trials = 2 * (18 * 13 * 10 if k.full else len(k.distances_m) * len(k.angles_deg) * k.repetitions)
    return _model(trials * k.queries, ("campaign.repetitions", "campaign.queries", "campaign.full",
                                       "campaign.distances_m", "campaign.angles_deg", "campaign.workers"),
                  base_mib=236, bytes_per_unit=4 * KiB, workers=k.workers, tasks=trials, held=trials)


#: Most beacon steps of a simulation-room trial: the longest rt of the thesis's tables (SIR at
#: σ0 = 9 dB; ``rfsim.scenes.rss_rooms.RECURSIONS``), used where ``recursions`` is 0.
RSS_MAX_STEPS = 20


def _rss_localization(c) -> Estimate:
    """Every case's rows, per trial and beacon step one read per reader and 6 more rows (the
    wide RSSI row, 5 estimates), 64 B each (7.3 KiB per trial and case measured at 3000 trials,
    the rows held until the write and joined once more there); the particle clouds of one
    case's trials at once (384 B per particle and trial: 94 -> 195 MiB from 2 × 50 to 2 × 200000
    trials × particles)."""
    trials = c.trials or 1000
    steps = c.home_steps if c.preset == "home-2room" else (c.recursions or RSS_MAX_STEPS)
    readers = len(c.readers_xy) if c.readers_xy is not None else c.n_readers
    return _model(trials * len(c.sigma0_db) * len(c.motions),
                  ("trials", "particles", "sigma0_db", "motions", "recursions"),
                  base_mib=120 + trials * c.particles * 384 / MiB, bytes_per_unit=steps * (readers + 6) * 64)


def _st_localization(c) -> Estimate:
    """Realization-seconds of tracking; ≤ 10 realizations' particle clouds at once (3 KiB per
    particle: its landmark probabilities; 263 MiB measured at 4 × 20000 particles, stopped)."""
    r = 500 if c.full else c.realizations
    speeds = len(c.speeds_mps) + len(c.trajectory_2_speeds_mps)
    seconds = r * speeds * c.path_duration_s + (c.walk_duration_s or 10000)
    return _model(seconds, ("realizations", "full", "path_duration_s", "walk_duration_s", "filters.particles"),
                  base_mib=120 + min(r, 10) * c.filters.particles * 3 * KiB / MiB, bytes_per_unit=2 * KiB,
                  workers=c.workers, tasks=max(r // 10, 1) * speeds)


def _tag_to_tag_tracking(c) -> Estimate:
    """Rows per trajectory, filter run and range (every tracker's estimate); the particle
    clouds of the filter runs of 5 trajectories at once (95 -> 112 MiB from 1 x 1 to 200 x 50)."""
    m = sum(c.trackers.particles) + sum(c.trackers.rbpf_particles)
    return _model(c.trajectories * c.filter_runs * len(c.ranges_m),
                  ("trajectories", "filter_runs", "ranges_m", "trackers.particles", "workers"),
                  base_mib=120 + 5 * c.filter_runs * m * 64 * 8 / MiB, bytes_per_unit=KiB, workers=c.workers,
                  tasks=math.ceil(c.trajectories / 5))


#: What compiling a scenario's kernels on a cold cache adds to the peak of its process [MiB]:
#: the peak of the smallest run of ``tests/test_resources.py`` on an empty kernel cache minus
#: its peak on a full one (measured, in the comments), rounded up to 10 MiB plus 10 MiB. The
#: scenarios without kernels of their own add nothing (the same peak on both caches).
COMPILE_MIB: dict[str, float] = {
    "access": 170,                 # the link scenario's kernels; a cold run's peak 265.9 MiB measured
    "detection-probability": 150,  # 299 - 163 MiB
    "exciter-link": 130,           # 313 - 202
    "gen2-waveforms": 30,          # 178 - 164
    "himr-1d": 40,                 # 253 - 225
    "himr-2d": 40,                 # 236 - 213
    "inventory": 180,              # 368 - 207
    "link": 150,                   # 293 - 162
    "phase-cancellation": 180,     # 341 - 213; a kernel plan's compiling child: 262.2 MiB measured
    "phase-tracking": 200,         # 360 - 176
    "reader-detection": 190,       # 332 - 204; a kernel plan's compiling child: 256.6, 265.0, then 270.7 MiB measured
    "rss-localization": 0,         # 94 - 94
    "st-localization": 0,          # 95 - 95
    "st-to-st": 110,               # 293 - 201
    "tag-to-tag-tracking": 0,      # 95 - 95
}

SIZE_MODELS: dict[str, Callable[..., Estimate]] = {
    "access": _access,
    "detection-probability": _detection_probability,
    "exciter-link": _exciter_link,
    "gen2-waveforms": _gen2_waveforms,
    "himr-1d": _himr,
    "himr-2d": _himr,
    "inventory": _inventory,
    "link": _link,
    "phase-cancellation": lambda c: _cells(c, "geometry.tag_x_m", len(c.geometry.tag_x_m)),
    "phase-tracking": _phase_tracking,
    "reader-detection": _reader_detection,
    "rss-localization": _rss_localization,
    "st-localization": _st_localization,
    "st-to-st": lambda c: _cells(c, "geometry.st_x_m", len(c.geometry.st_x_m)),
    "tag-to-tag-tracking": _tag_to_tag_tracking,
}

__all__ = ["COMPILE_MIB", "RSS_MAX_STEPS", "SIZE_MODELS", "estimate_of"]
