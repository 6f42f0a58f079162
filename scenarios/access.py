"""Scenario ``access``: read range and write range of one tag, the reader running an access program.

One reader and one tag (the ``link`` scenario's geometry: a patch reader antenna and a dipole tag
facing it) at a sweep of distances, N trials per distance. A trial is a sample-level
singulation (Query → RN16 → ACK → PC+EPC+CRC-16) followed by the access program
(:mod:`rfsim.protocols.access_sequence`; default Req_RN → Read TID[0:4] → Read User[0:4] →
Req_RN, Write User[2]), every command one exchange of the engine over the trial's channel draw,
with the standard's T2/T4 timing and the Write's delayed reply (T5 ≤ 20 ms). The tag's memory is
``memory`` (:class:`rfsim.gen2.memory.TagMemoryConfig`: the chip model and its contents).

Physics expectation: a Write needs more power at the chip than a read — the chip's write
threshold Δ = write sensitivity − read sensitivity (:class:`rfsim.gen2.memory.ChipModel`; 3 dB
for the generic chip) — so Writes fail first (error 0Bh, insufficient power) as the tag moves
away. In free space (the default: no floor, no diffuse taps) the incident power falls as d⁻²
(Friis), so the write range is the read range times 10^(−Δ/20) (0.71 for 3 dB) when the read
range is set by the tag's power-up (the forward link), as it is for a passive tag.

Dataset: ``reads`` (one row per trial: the singulation in the per-read schema,
:mod:`rfsim.core.reads`), ``accesses`` (one row per access command, keyed to its read by
``point`` and ``round``), ``rates`` (per distance: EPC read, TID read and Write success rates
with Wilson 95 % intervals) and the root attributes ``read_range_m``, ``tid_range_m``,
``write_range_m`` (the largest distance at which the rate is ≥ 50 %, interpolated linearly
between the grid's distances; NaN when the rate does not cross 50 % inside the grid),
``range_gap_m`` and ``range_ratio`` (write / read) beside ``friis_ratio`` = 10^(−Δ/20).

Randomness: point i, round r uses ``trial_rng(seed, i, r)`` for the channel draw and the
receiver noise of every command of the trial; the reader and the tag of point i have their own
streams ``trial_rng(seed, i, n_rounds)`` and ``trial_rng(seed, i, n_rounds + 1)``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.core.lazy import lazy_import
from rfsim.core.progress import track
from rfsim.core.reads import reads_table
from rfsim.core.records import READ_MEASUREMENT_FIELDS, epc_hex, long_table, time_stamp_us
from rfsim.core.rng import trial_rng
from rfsim.devices.reader_config import ReaderConfig
from rfsim.devices.tag_config import TagConfig
from rfsim.gen2.memory import TagMemoryConfig
from rfsim.protocols.access_program import ACCESS_FIELDS, DEFAULT_PROGRAM, parse_program
from rfsim.scenarios.link import ChannelConfig, GeometryConfig, reader_antenna, scene, tag_antenna

_access = lazy_import("rfsim.protocols.access_sequence")
_scene = lazy_import("rfsim.channels.scene")
_reader = lazy_import("rfsim.devices.reader")
_tag = lazy_import("rfsim.devices.tag")
_dataset = lazy_import("rfsim.core.dataset")
_commands = lazy_import("rfsim.gen2.commands")
_memory = lazy_import("rfsim.gen2.memory")
_fit = lazy_import("rfsim.detection.fit")

NAME = "access"
DESCRIPTION = "reader + one tag at swept distance running an access program: read rate vs Write success (read/write range)"

#: Rate at which a range is read off the rate curve.
RANGE_RATE = 0.5


@dataclass(frozen=True)
class Config:
    """Configuration of the ``access`` scenario.

    Attributes
    ----------
    geometry : rfsim.scenarios.link.GeometryConfig
        Placement of the reader antenna and the tag (distances 0.5–8 m by default).
    channel : rfsim.scenarios.link.ChannelConfig
        Propagation terms; default free space (no floor, no APDP taps).
    reader : rfsim.devices.reader_config.ReaderConfig
        Reader settings.
    tag : rfsim.devices.tag_config.TagConfig
        Tag settings.
    memory : rfsim.gen2.memory.TagMemoryConfig
        The tag's chip model (write time, write threshold, bank sizes) and memory contents (User words
        0–3 set for the default Reads; the EPC is the tag's ``epc_hex``).
    program : tuple of str
        The access program (:func:`rfsim.protocols.access_program.parse_program`).
    rounds_per_point : int, default 6
        Trials per distance, in [1, 100000].
    round_period_s : float, default 0.1
        Time between trial starts [s], in [0.05, 10] (the longest program fits in 50 ms).
    t2_tpri : float, default 10.0
        T2 from a reply's end to the next command [Tpri], in [3, 20].
    """

    geometry: GeometryConfig = param(GeometryConfig(distances_m=(0.5, 1.0, 2.0, 3.0, 3.5, 4.0, 4.5, 5.0, 5.5, 6.0,
                                                                 7.0, 8.0)), doc="placement")
    channel: ChannelConfig = param(ChannelConfig(apdp=False, floor=False), doc="propagation (default: free space)")
    reader: ReaderConfig = param(ReaderConfig(), doc="reader")
    tag: TagConfig = param(TagConfig(), doc="tag")
    memory: TagMemoryConfig = param(TagMemoryConfig(user="0123456789ABCDEF"), doc="the tag's chip and memory")
    program: tuple[str, ...] = param(DEFAULT_PROGRAM, doc="access program: req_rn, 'read <bank> <ptr> <count>', "
                                                          "'write <bank> <ptr> <word>', blockwrite, blockerase, lock, "
                                                          "access, kill (rfsim.protocols.access_program)")
    rounds_per_point: int = param(6, lo=1, hi=100000, doc="trials per distance")
    round_period_s: float = param(0.1, lo=0.05, hi=10.0, unit="s", doc="time between trial starts")
    t2_tpri: float = param(10.0, lo=3.0, hi=20.0, unit="Tpri", doc="T2: a reply's end to the next command")

    def __post_init__(self):
        parse_program(list(self.program), "program")
        if self.memory.epc != self.tag.epc_hex.replace(" ", ""):
            raise ConfigError("memory.epc", self.memory.epc, f"the tag's EPC tag.epc_hex = "
                                                              f"{self.tag.epc_hex!r} (set both)")


def tag_memory(tag: TagConfig, memory: TagMemoryConfig):
    """The memory of a tag: ``memory`` with the tag's own EPC.

    Parameters
    ----------
    tag : rfsim.devices.tag_config.TagConfig
        The tag (its ``epc_hex``).
    memory : rfsim.gen2.memory.TagMemoryConfig
        The chip model and contents (factory TID of the chip, User words).

    Returns
    -------
    rfsim.gen2.memory.TagMemory
        A new memory (each tag changes its own).
    """
    return _memory.TagMemory(replace(memory, epc=tag.epc_hex.replace(" ", "")))


READ_FIELDS = {
    "point": ("1", "index of the distance point"),
    "round": ("1", "trial at this point"),
    "time_s": ("s", "start of the trial's Query"),
    "distance_m": ("m", "reader antenna to tag distance of the point (geometry.distances_m)"),
    **READ_MEASUREMENT_FIELDS,
    "success": ("1", "EPC decoded with CRC ok (the access program ran)"),
    "failure_reason": ("", "why the EPC read failed ('' = success)"),
    "tag_incident_power_dbm": ("dBm", "CW power incident at the tag antenna port (Query)"),
}


def run(config: Config, *, seed: int) -> _dataset.Dataset:
    """Singulate the tag and run the access program at each distance, N trials each.

    Parameters
    ----------
    config : Config
        Scenario configuration.
    seed : int
        Root seed (streams: module docstring).

    Returns
    -------
    rfsim.core.dataset.Dataset
        Tables ``reads``, ``accesses`` and ``rates``, and the ranges as root attributes (module
        docstring).
    """
    g, n_rounds = config.geometry, config.rounds_per_point
    program = parse_program(list(config.program), "program")
    antenna = reader_antenna(g)
    n_points = len(g.distances_m)
    readers = [_reader.Reader(config.reader, [antenna], rng=trial_rng(seed, i, n_rounds)) for i in range(n_points)]
    tags = [[_tag.PassiveTag(config.tag, tag_antenna(g, d), rng=trial_rng(seed, i, n_rounds + 1),
                             memory=tag_memory(config.tag, config.memory))] for i, d in enumerate(g.distances_m)]
    channels = [_scene.Channel(scene(config.channel)) for _ in range(n_points)]
    lk = readers[0].link
    reads: dict[str, list] = {k: [] for k in (*READ_FIELDS, "epc")}
    accesses: list[dict] = []
    for r in track(range(n_rounds), desc="trials", unit="trials"):
        times = [(i * n_rounds + r) * config.round_period_s for i in range(n_points)]
        query = _commands.Query(dr=lk.dr, m=lk.m, trext=lk.trext, q=0, target="AB"[r % 2])
        runs = _access.run_access_batch(readers, tags, channels, t_s=times,
                                        rngs=[trial_rng(seed, i, r) for i in range(n_points)], query=query,
                                        program=program, round_index=r, t2_tpri=config.t2_tpri)
        for i, (d, run_) in enumerate(zip(g.distances_m, runs)):
            last = run_.singulation[-1]
            ok = run_.epc_ok
            read = last.read if ok else None
            for k, v in dict(point=i, round=r, time_s=times[i], distance_m=d, antenna=last.antenna + 1,
                             channel_index=last.channel_index, frequency_hz=last.fc_hz,
                             rssi_dbm=read.rssi_dbm if ok else np.nan, phase_rad=read.phase_rad if ok else np.nan,
                             doppler_hz=read.doppler_hz if ok else np.nan, snr_db=read.snr_db if ok else np.nan,
                             success=ok, epc=epc_hex(read.bits) if ok else "",
                             failure_reason=last.failure_reason,
                             tag_incident_power_dbm=run_.singulation[0].incident_power_dbm[0]).items():
                reads[k].append(v)
            cols = _access.access_columns([run_])
            cols.pop("trial")
            accesses.append({"point": np.full(cols["step"].size, i), "round": np.full(cols["step"].size, r),
                             "distance_m": np.full(cols["step"].size, float(d)), **cols})
    return _dataset_of(config, program, reads, accesses)


def _dataset_of(config: Config, program, reads: dict, accesses: list) -> _dataset.Dataset:
    """The tables and attributes of a run (module docstring)."""
    cols = {k: np.asarray(v) for k, v in reads.items()}
    cols["t_us"] = time_stamp_us(cols["time_s"])
    cols["reported"] = cols["success"]
    cols = long_table(cols)
    g = config.geometry
    tag_m = np.array([tag_antenna(g, d).position_m for d in g.distances_m])[cols["point"]]
    ds = _dataset.Dataset(title="reader-tag access program vs distance: read range and write range")
    ds.add_table("reads", reads_table(cols, READ_FIELDS, true_position_m=tag_m,
                                      notes={"true_incident_power_dbm": "during the trial's Query"}),
                 description="one row per trial (Query, RN16, ACK, EPC) at each distance, sorted by time stamp: "
                             "the singulation that starts the access program, keyed by point and round")
    acc = {k: np.concatenate([a[k] for a in accesses]) for k in accesses[0]}
    fields = {"point": READ_FIELDS["point"], "round": READ_FIELDS["round"],
              "distance_m": READ_FIELDS["distance_m"], **ACCESS_FIELDS}
    ds.add_table("accesses", {k: _dataset.column(acc[k], *fields[k]) for k in fields},
                 description="one row per access command of each trial (Req_RN, Read, Write, ...), keyed to its read "
                             "in 'reads' by point and round")
    rates, attrs = _rates(config, program, cols, acc)
    ds.add_table("rates", rates, description="one row per distance: EPC read, TID read and Write success rates "
                                             "with Wilson 95 % intervals")
    ds.attrs.update(attrs)
    return ds


def range_m(distances_m, rate, level: float = RANGE_RATE) -> float:
    """The largest distance at which ``rate`` is at least ``level``, interpolated.

    The last grid distance with rate ≥ ``level`` followed by one below; the range is where the
    straight line between the two crosses ``level``.

    Parameters
    ----------
    distances_m : (n,) float
        Increasing distances [m].
    rate : (n,) float
        Success rate at each distance [1].
    level : float, default 0.5
        The rate that defines the range [1].

    Returns
    -------
    float
        The range [m]; NaN if the rate is below ``level`` at the first distance or never falls
        below it.
    """
    d, p = np.asarray(distances_m, float), np.asarray(rate, float)
    above = np.flatnonzero(p >= level)
    if above.size == 0 or above[0] != 0 or above[-1] == d.size - 1:
        return float("nan")
    i = above[-1]
    return float(d[i] + (d[i + 1] - d[i]) * (p[i] - level) / (p[i] - p[i + 1]))


def _rates(config: Config, program, reads: dict, acc: dict) -> tuple[dict, dict]:
    """Per-distance rates with Wilson intervals, and the ranges (module docstring)."""
    d = np.asarray(config.geometry.distances_m, float)
    tid = next((k for k, s in enumerate(program) if s.op == "read" and s.membank == 2), -1)
    write = next((k for k, s in enumerate(program) if s.op == "write"), -1)
    out, attrs = {"distance_m": _dataset.column(d, "m", "reader antenna to tag distance")}, {}
    n = np.array([np.sum(reads["point"] == i) for i in range(d.size)])
    out["trials"] = _dataset.column(n, "1", "trials at this distance")
    for name, what, step, command in (("read", "EPC read (singulation, CRC ok)", None, None),
                                      ("tid", "TID read (the program's first Read of the TID bank, ok)", tid, "Read"),
                                      ("write", "Write (the program's first Write, success reply)", write, "Write")):
        if step is None:
            k = np.array([np.sum(reads["success"][reads["point"] == i]) for i in range(d.size)])
        else:
            hit = (acc["step"] == step) & (acc["command"] == command) & (acc["result"] == "ok")
            k = np.array([np.sum(hit & (acc["point"] == i)) for i in range(d.size)])
        lo, hi = _fit.wilson_interval(k, n)
        rate = np.where(n > 0, k / np.maximum(n, 1), np.nan)
        out[f"{name}_successes"] = _dataset.column(k, "1", f"trials with a successful {what}")
        out[f"{name}_rate"] = _dataset.column(rate, "1", f"{what} rate")
        out[f"{name}_rate_lo"] = _dataset.column(lo, "1", f"{what} rate, Wilson 95 % lower bound")
        out[f"{name}_rate_hi"] = _dataset.column(hi, "1", f"{what} rate, Wilson 95 % upper bound")
        attrs[f"{name}_range_m"] = range_m(d, rate) if step != -1 else float("nan")
    power = (acc["command"] == "Write") & (acc["error_code"] == int(_memory.TagError.INSUFFICIENT_POWER))
    out["write_power_errors"] = _dataset.column(np.array([np.sum(power & (acc["point"] == i)) for i in range(d.size)]),
                                                "1", "Writes answered with error 0Bh (insufficient power)")
    delta_db = config.memory.chip_model.write_threshold_db
    attrs.update(range_gap_m=attrs["read_range_m"] - attrs["write_range_m"],
                 range_ratio=attrs["write_range_m"] / attrs["read_range_m"], write_threshold_db=delta_db,
                 friis_ratio=10.0 ** (-delta_db / 20.0), range_rate=RANGE_RATE,
                 program="; ".join(s.text for s in program), t2_tpri=config.t2_tpri)
    for key in [k for k, v in attrs.items() if isinstance(v, float) and not np.isfinite(v)]:
        attrs[f"{key}_meaning"] = ("NaN: a range is NaN" if key in ("range_gap_m", "range_ratio") else
                                   "NaN: the rate does not cross 50 % inside the distance grid, or the program "
                                   "has no such step")
    return out, attrs


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """Read, TID-read and Write success rates vs distance with the read and write ranges,
    ``<stem>-ranges.png`` (:mod:`rfsim.scenarios._access_figures`).

    Parameters
    ----------
    dataset_path : pathlib.Path
        A dataset written by :func:`run`.
    out_dir : pathlib.Path
        Folder of the figure.

    Returns
    -------
    list of pathlib.Path
        The written figure.
    """
    from rfsim.scenarios._access_figures import plot_ranges

    return plot_ranges(dataset_path, out_dir)
