"""Scenario ``inventory``: a reader inventories N tags at random positions in a room.

Every inventory runs the Gen2 Q algorithm (:mod:`rfsim.protocols.inventory`) at sample level through
the engine: the reader's PIE commands, every tag's power-up, PIE decoding and state machine,
the superposition of all RN16/EPC replies at the reader and its receiver. Collisions and
capture therefore emerge from the waveforms (gen2-and-validation-anchors.md §4.4–4.6).

Scene (:mod:`rfsim.scenes.room_inventory`): tags at random in a room, one to four reader
patches in the middle of the walls, used in turn per round; Friis LoS, optional floor
reflection and the exponential APDP (PASS room curves), drawn per round and held within it.

Tables:

* ``slots``: one row per slot (see :data:`rfsim.protocols.inventory.SLOT_FIELDS`) with the population
  and run;
* ``reads``: one row per EPC read (:data:`rfsim.protocols.inventory.READ_FIELDS`), as the ``link``
  scenario's reads;
* ``inventories``: one row per inventory (tags read, slots, air time, efficiency);
* ``capture``: two tags in the same slot at different distances on the boresight of a
  patch; capture (:func:`rfsim.scenes.capture_sweep.captured`, as ``capture_sweep``) against
  the modulated power ratio of the two replies at the reader (``capture_sweep``'s x-axis). The
  replies of identical tags (same clock, same T1) are synchronous and share the preamble, so
  the receiver's gain estimate is h1 + h2 and a bit where the tags differ is decided by the
  sign of ``|h1|² − |h2|²``: capture needs only a power ratio that the noise cannot mask, and
  fails when h1 + h2 ≈ 0 (the preamble cancels). At ``capture.noise_figure_db`` = 40 dB the
  stronger reply still arrives at Eb/N0 ≈ 35 dB, with no RN16 gate: why this table's 0.80
  below 1 dB and ``capture_sweep``'s 0.04 at 0 dB differ, measured, in
  :data:`rfsim.scenes.capture_sweep.TABLES_COMPARED` (both tables' descriptions).
* ``tags``: one row per tag of every inventory: position, orientation and the tag's own
  spread (``spread``, :mod:`rfsim.devices.tag_spread`: BLF error within FrT, T1 within
  [T1min, T1max], chip states, antenna yaw/roll; off by default, then zeros and the nominal
  T1). Tags with spread need ``reader.blf_search = "preamble"``.
* ``capture_sweep``, ``capture_trials``, ``acceptance`` (``capture_sweep``,
  :mod:`rfsim.scenes.capture_sweep`): P(capture) against the modulated power ratio of two
  colliding RN16 replies, 0–15 dB, FM0 (``fm0-40k``) and Miller-4 (``miller4-320k``), with
  and without the tags' spread, ``capture_sweep.trials`` collisions per point with the
  Clopper–Pearson 95 % interval; the reader's BLF search and RN16 acceptance
  (:func:`rfsim.devices.reader.search_decode`, :func:`rfsim.devices.reader.rn16_threshold_db`) on a
  stacked array of RN16 windows; the false-ACK and missed-capture rates against the
  acceptance threshold on the same collisions.
* ``capture_inventories`` (``capture_inventory.enabled``, off by default): a population with
  spread in a 4 m × 3 m room (every tag powered) inventoried at sample level with capture,
  at sample level with capture switched off
  (:class:`rfsim.protocols.no_capture.NoCaptureAir`) and at protocol level:
  slots and air time to read every tag, efficiency, captures, false ACKs. Measured (seed 1,
  3 runs each, N = 10/50/100/200): slots until the last tag read 19/69/145/287 with capture,
  23/131/287/583 without, 23/144/295/590 at protocol level; air time 29/138/280/559 ms with
  capture against 31/161/333/670 ms without; slot efficiency 0.42–0.68 with capture against
  0.34–0.36 (1–4 of 200 tags stay unpowered at sample level in that room and are never read).

Randomness: population p, run r: tag positions ``trial_rng(seed, p, r, 0)``, reader hop table
``trial_rng(seed, p, r, 1)``, channel and receiver noise ``trial_rng(seed, p, r, 2)``, tag k's
own stream ``trial_rng(seed, p, r, 3, k)``; capture point i, trial j: ``trial_rng(seed,
10**6 + i, j, ...)``; tag k's spread ``trial_rng(seed, p, r, 3, k, 0)``; capture-sweep point p
``trial_rng(seed, 2·10**6 + p)``; capture inventories ``trial_rng(seed, 3·10**6 + p, r, ...)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from rfsim.core.config import check_fields, param
from rfsim.core.errors import ConfigError
from rfsim.core.lazy import lazy_import
from rfsim.core.progress import track
from rfsim.devices.reader_config import ReaderConfig
from rfsim.devices.tag_config import TagConfig
from rfsim.devices.tag_spread import SPREAD_FIELDS, TagSpreadConfig
from rfsim.protocols.inventory import READ_FIELDS, SLOT_FIELDS, InventoryConfig, ProtocolAir, run_inventory
from rfsim.protocols.no_capture import NoCaptureAir
from rfsim.scenes import capture_sweep as sweep
from rfsim.scenes.room_inventory import (CAPTURE_FIELDS, RoomConfig, boresight_capture_rows,  # noqa: F401
                                         make_tags, reader_antennas, room_air, room_population, room_reads, tag_antenna)

_dataset = lazy_import("rfsim.core.dataset")
_link = lazy_import("rfsim.gen2.link")
_figures = lazy_import("rfsim.scenarios._inventory_figures")
_arrays = lazy_import("rfsim.devices.gen2_tag_arrays")

NAME = "inventory"
DESCRIPTION = "Q-algorithm inventory of N tags in a room at sample level: slots, reads, capture"


@dataclass(frozen=True)
class CaptureConfig:
    """The two-tag capture experiment: a near and a far tag in one Q = 0 slot on a patch's boresight.

    Attributes
    ----------
    enabled : bool, default True
        Run the two-tag capture experiment.
    near_m : float, default 3.0
        Distance of the near tag [m], in [0.2, 5].
    ratios_db : tuple of float, default (0.0, 0.25, 0.5, 1.0, 2.0, 4.0)
        Nominal backscatter power ratios (far tag at near·10^(r/40)) [dB], in [0, 30].
    trials : int, default 20
        Trials per ratio, in [1, 100000].
    noise_figure_db : float, default 40.0
        Reader noise figure in this experiment (sets the SNR of the replies) [dB], in [0, 80].
    """

    enabled: bool = param(True, doc="run the two-tag capture experiment")
    near_m: float = param(3.0, lo=0.2, hi=5.0, unit="m", doc="distance of the near tag")
    ratios_db: tuple[float, ...] = param((0.0, 0.25, 0.5, 1.0, 2.0, 4.0), lo=0.0, hi=30.0, unit="dB",
                                         doc="nominal backscatter power ratios (far tag at near·10^(r/40))")
    trials: int = param(20, lo=1, hi=100000, doc="trials per ratio")
    noise_figure_db: float = param(40.0, lo=0.0, hi=80.0, unit="dB",
                                   doc="reader noise figure in this experiment (sets the SNR of the replies)")

    def __post_init__(self):
        check_fields(self, "capture")


@dataclass(frozen=True)
class CaptureInventoryConfig:
    """Inventories of populations with spread, with capture on and off, beside the protocol level.

    Attributes
    ----------
    enabled : bool, default False
        Inventories with capture on/off at sample level beside the protocol level.
    populations : tuple of int, default (10, 50, 100, 200)
        Numbers of tags N, in [1, 2000].
    runs : int, default 1
        Inventories per population and mode, in [1, 1000].
    room : rfsim.scenes.room_inventory.RoomConfig
        Room of these inventories (4 m × 3 m: every tag powered, so 'slots to read all' exists).
    """

    enabled: bool = param(False, doc="inventories with capture on/off at sample level beside the protocol level")
    populations: tuple[int, ...] = param((10, 50, 100, 200), lo=1, hi=2000, doc="numbers of tags N")
    runs: int = param(1, lo=1, hi=1000, doc="inventories per population and mode")
    room: RoomConfig = param(RoomConfig(length_m=4.0, width_m=3.0),
                             doc="room of these inventories (4 m × 3 m: every tag powered, so 'slots to read all' "
                                 "exists)")

    def __post_init__(self):
        check_fields(self, "capture_inventory")


@dataclass(frozen=True)
class Config:
    """Configuration of the ``inventory`` scenario.

    ``spread.enabled`` needs ``reader.blf_search = "preamble"`` (checked by :func:`run`).

    Attributes
    ----------
    room : rfsim.scenes.room_inventory.RoomConfig
        Room and reader placement.
    reader : rfsim.devices.reader_config.ReaderConfig
        Reader settings.
    tag : rfsim.devices.tag_config.TagConfig
        Tag template (EPCs are numbered per tag).
    inventory : rfsim.protocols.inventory.InventoryConfig
        Inventory control (Q algorithm).
    populations : tuple of int, default (5, 10, 20)
        Numbers of tags N, in [1, 2000].
    runs : int, default 2
        Independent inventories per population, in [1, 10000].
    capture : CaptureConfig
        Capture experiment.
    spread : rfsim.devices.tag_spread.TagSpreadConfig
        Tag-to-tag spread of the populations (off: identical tags).
    capture_sweep : rfsim.scenes.capture_sweep.CaptureSweepConfig
        Batched two-tag capture sweep and RN16 acceptance.
    capture_inventory : CaptureInventoryConfig
        Inventories with capture on and off (tags with spread).
    """

    room: RoomConfig = param(RoomConfig(), doc="room and reader placement")
    reader: ReaderConfig = param(ReaderConfig(), doc="reader")
    tag: TagConfig = param(TagConfig(), doc="tag template (EPCs are numbered per tag)")
    inventory: InventoryConfig = param(InventoryConfig(), doc="inventory control (Q algorithm)")
    populations: tuple[int, ...] = param((5, 10, 20), lo=1, hi=2000, doc="numbers of tags N")
    runs: int = param(2, lo=1, hi=10000, doc="independent inventories per population")
    capture: CaptureConfig = param(CaptureConfig(), doc="capture experiment")
    spread: TagSpreadConfig = param(TagSpreadConfig(), doc="tag-to-tag spread of the populations (off: identical tags)")
    capture_sweep: sweep.CaptureSweepConfig = param(sweep.CaptureSweepConfig(),
                                                    doc="batched two-tag capture sweep and RN16 acceptance")
    capture_inventory: CaptureInventoryConfig = param(CaptureInventoryConfig(),
                                                      doc="inventories with capture on and off (tags with spread)")


# ----------------------------------------------------------------------------- run


CAPTURE_INVENTORY_FIELDS = {
    "population": ("1", "number of tags N"),
    "run": ("1", "index of the inventory run for this population and mode"),
    "mode": ("", "capture (sample level, tags with spread, RN16 acceptance), no-capture (the same, a slot with "
                 ">= 2 replies never decoded) or protocol (state machines only, no capture)"),
    "tags_read": ("1", "distinct tags read"),
    "slots": ("1", "slots of the whole inventory"),
    "slots_to_all": ("1", "slots until every tag was read (-1 if not all)"),
    "air_time_to_all_s": ("s", "air time until every tag was read (NaN if not all)"),
    "air_time_s": ("s", "air time of the whole inventory"),
    "slots_to_read": ("1", "slots until the last tag this inventory read was read (tags the room leaves "
                           "unpowered are never read at sample level)"),
    "air_time_to_read_s": ("s", "air time until the last tag this inventory read was read"),
    "efficiency": ("1", "successful slots (reads, captures included) / slots"),
    "captures": ("1", "slots read although >= 2 tags replied"),
    "false_acks": ("1", "ACKs no tag answered (the RN16 accepted was no tag's)"),
}


def capture_inventories(config: Config, *, seed: int) -> dict[str, list]:
    """For each N and run: the same population (positions, spread, tag streams) inventoried
    three ways (:data:`CAPTURE_INVENTORY_FIELDS` ``mode``). Streams: population p, run r:
    ``trial_rng(seed, 3_000_000 + p, r, ...)`` as the main inventories.

    Parameters
    ----------
    config : Config
        Scenario configuration (``capture_inventory`` and, for the tags' spread and the RN16
        acceptance, ``capture_sweep``).
    seed : int
        Root seed.

    Returns
    -------
    dict of str to list
        Columns of the ``capture_inventories`` table, keys of
        :data:`CAPTURE_INVENTORY_FIELDS`: one entry per (population, run, mode).
    """
    ci, cs = config.capture_inventory, config.capture_sweep
    rows: dict[str, list] = {k: [] for k in CAPTURE_INVENTORY_FIELDS}
    reader_cfg = replace(config.reader, blf_search="preamble", rn16_false_accept=cs.rn16_false_accept)
    room = ci.room
    antennas = reader_antennas(room)
    plan = [(p, n, r, mode) for p, n in enumerate(ci.populations) for r in range(ci.runs)
            for mode in ("capture", "no-capture", "protocol")]
    for p, n, r, mode in track(plan, desc="inventories with capture on/off", unit="inventories"):
        key = (3_000_000 + p, r)
        reader, tags = room_population(room, reader_cfg, config.tag, n, antennas, seed=seed, key=key, spread=cs.spread)
        air = ProtocolAir(reader.link, tags, arrays=_arrays.StateArrays) if mode == "protocol" else \
            room_air(room, reader, tags, seed=seed, key=key, keep_exchanges=True)
        log = run_inventory(NoCaptureAir(air) if mode == "no-capture" else air, config.inventory)
        done = log.completion(n)
        n_read = len(log.tags_read())
        last = log.completion(n_read) if n_read else None
        types = log.slots["slot_type"]
        acks = [e for e in (getattr(air, "exchanges", None) or []) if e.command == "ACK"]
        for k, v in dict(population=n, run=r, mode=mode, tags_read=n_read, slots=log.n_slots,
                         slots_to_all=done[0] if done else -1, air_time_to_all_s=done[1] if done else math.nan,
                         air_time_s=log.air_time_s, slots_to_read=last[0] if last else 0,
                         air_time_to_read_s=last[1] if last else 0.0,
                         efficiency=sum(t in ("success", "capture") for t in types) / max(log.n_slots, 1),
                         captures=types.count("capture"), false_acks=sum(1 for e in acks if not e.replied)).items():
            rows[k].append(v)
    return rows


INVENTORY_FIELDS = {
    "population": ("1", "number of tags N"),
    "run": ("1", "index of the inventory run for this population (new tag positions and draws)"),
    "tags_read": ("1", "distinct tags read"),
    "read_rate": ("1", "fraction of the N tags read"),
    "slots": ("1", "slots of the whole inventory"),
    "air_time_s": ("s", "air time of the whole inventory"),
    "slots_to_all": ("1", "slots until every tag read at least once (-1 if not all)"),
    "air_time_to_all_s": ("s", "air time until every tag read (NaN if not all)"),
    "efficiency": ("1", "successful slots / slots of the inventory"),
}


TAG_FIELDS = {
    "population": ("1", "number of tags N"),
    "run": ("1", "index of the inventory run for this population"),
    "tag": ("1", "tag index (the EPC's number - 1)"),
    "x_m": ("m", "tag antenna position x"),
    "y_m": ("m", "tag antenna position y"),
    "z_m": ("m", "tag antenna position z"),
    "yaw_rad": ("rad", "tag antenna yaw (orientation offset included)"),
    "roll_rad": ("rad", "tag antenna roll (orientation offset included)"),
    **SPREAD_FIELDS,
}


def _tag_rows(rows: dict, n: int, r: int, tags: list, recs: list, t1_nom_s: float) -> None:
    """Append one row per tag (geometry and its spread record; zeros and the nominal T1
    ``t1_nom_s`` without spread)."""
    zero = dict.fromkeys(SPREAD_FIELDS, 0.0)
    for k, t in enumerate(tags):
        rec = recs[k] if recs else dict(zero, t1_s=t1_nom_s)
        pos, ori = t.antenna.position_m, t.antenna.orientation
        for key, v in dict(population=n, run=r, tag=k, x_m=float(pos[0]), y_m=float(pos[1]), z_m=float(pos[2]),
                           yaw_rad=ori[0], roll_rad=ori[2], **rec).items():
            rows[key].append(v)


def run(config: Config, *, seed: int) -> _dataset.Dataset:
    """Simulate Q-algorithm inventories of tag populations in a room at sample level.

    Each population size N is inventoried ``runs`` times (new positions and draws per run);
    collisions and capture emerge from the superposed waveforms
    (gen2-and-validation-anchors.md §4.4–4.6). The capture experiments of the module
    docstring run as configured.

    Parameters
    ----------
    config : Config
        Scenario configuration.
    seed : int
        Root seed (the streams of the module docstring).

    Returns
    -------
    rfsim.core.dataset.Dataset
        Tables ``slots`` (one row per slot), ``reads`` (one row per EPC read, per-read
        schema), ``inventories`` (one row per inventory: tags read, slots, air time [s],
        efficiency) and ``tags`` (one row per tag: position [m], orientation [rad], spread);
        when enabled, ``capture_sweep``, ``capture_trials`` and ``acceptance`` (the batched
        capture sweep), ``capture_inventories`` and ``capture`` (the boresight two-tag
        trials against the power ratio [dB]).

    Raises
    ------
    rfsim.core.errors.ConfigError
        ``spread.enabled`` without ``reader.blf_search = "preamble"``.
    """
    if config.spread.enabled and config.reader.blf_search != "preamble":
        raise ConfigError("spread.enabled", True, "with reader.blf_search = 'preamble' (tags with their own BLF "
                                                  "need a reader that estimates it)")
    slots: dict[str, list] = {k: [] for k in ("population", "run", *SLOT_FIELDS)}
    reads: dict[str, list] = {k: [] for k in ("population", "run", *READ_FIELDS)}
    inv: dict[str, list] = {k: [] for k in INVENTORY_FIELDS}
    tag_rows: dict[str, list] = {k: [] for k in TAG_FIELDS}
    room = config.room
    antennas = reader_antennas(room)
    for p, n in enumerate(config.populations):
        for r in track(range(config.runs), desc=f"inventories of {n} tags", unit="runs"):
            recs: list = []
            reader, tags = room_population(room, config.reader, config.tag, n, antennas, seed=seed, key=(p, r),
                                           spread=config.spread, records=recs)
            _tag_rows(tag_rows, n, r, tags, recs, _link.t1(reader.link).nom_s)
            air = room_air(room, reader, tags, seed=seed, key=(p, r))
            log = run_inventory(air, config.inventory)
            for k in SLOT_FIELDS:
                slots[k].extend(log.slots[k])
            for k in READ_FIELDS:
                reads[k].extend(log.reads[k])
            slots["population"].extend([n] * log.n_slots)
            slots["run"].extend([r] * log.n_slots)
            reads["population"].extend([n] * len(log.reads["time_s"]))
            reads["run"].extend([r] * len(log.reads["time_s"]))
            done = log.completion(n)
            n_read = len(log.tags_read())
            succ = sum(1 for v in log.slots["reader_view"] if v == "success")
            for k, v in dict(population=n, run=r, tags_read=n_read, read_rate=n_read / n, slots=log.n_slots,
                             air_time_s=log.air_time_s, slots_to_all=done[0] if done else -1,
                             air_time_to_all_s=done[1] if done else math.nan,
                             efficiency=succ / max(log.n_slots, 1)).items():
                inv[k].append(v)
    ds = _dataset.Dataset(title="Q-algorithm inventory of tags in a room: slots, reads, capture")
    units = {"population": ("1", "number of tags N"), "run": INVENTORY_FIELDS["run"]}
    tables = [("slots", slots, {**SLOT_FIELDS, **units}, "one row per slot of every inventory: what the reader saw and "
               "what happened (ground truth), the Q algorithm's state"),
              ("reads", reads, {**READ_FIELDS, **units}, "one row per EPC read (CRC ok): the reader's per-read report"),
              ("inventories", inv, INVENTORY_FIELDS, "one row per inventory (population, run): tags read, slots, air "
               "time, efficiency"),
              ("tags", tag_rows, TAG_FIELDS, "one row per tag of every inventory: position, antenna orientation and "
               "the tag's own spread (BLF error, T1, chip states; zeros / nominal T1 without spread)")]
    if config.capture_sweep.enabled:
        rows, trials, accept = sweep.tables(config.capture_sweep, sweep.run_sweep(config.capture_sweep, seed=seed))
        tables += [("capture_sweep", rows, sweep.POINT_FIELDS, "one row per point (profile, spread, power ratio) of "
                    "the batched two-tag capture sweep: P(capture) with its Clopper-Pearson interval, false ACKs. "
                    + sweep.TABLES_COMPARED),
                   ("capture_trials", trials, sweep.TRIAL_FIELDS, "one row per collision of the capture sweep: what "
                    "the reader decoded, its acceptance statistic, the two tags' BLF errors and T1"),
                   ("acceptance", accept, sweep.ACCEPT_FIELDS, "RN16 acceptance threshold against false-ACK and "
                    "missed-capture rates over the collisions of the capture sweep (ratios pooled), per profile "
                    "and spread")]
    if config.capture_inventory.enabled:
        tables.append(("capture_inventories", capture_inventories(config, seed=seed), CAPTURE_INVENTORY_FIELDS,
                       "one row per inventory of a population with spread, with capture on and off at sample level "
                       "and at protocol level: slots and air time to read every tag"))
    if config.capture.enabled:
        cap = config.capture
        rows = boresight_capture_rows(room, replace(config.reader, noise_figure_db=cap.noise_figure_db), config.tag,
                                      near_m=cap.near_m, ratios_db=cap.ratios_db, trials=cap.trials,
                                      session=config.inventory.session, seed=seed)
        tables.append(("capture", rows, CAPTURE_FIELDS, "one row per capture trial: two tags in one Q = 0 slot at a "
                       "set backscatter power ratio; whether the reader captured one. " + sweep.TABLES_COMPARED))
    for name, cols, fields, description in tables:  # reads: in the per-read schema (rfsim.core.reads)
        ds.add_table(name, room_reads(cols, fields, tag_rows, room) if name == "reads" else
                     {k: _dataset.column(np.asarray(v), *fields[k]) for k, v in cols.items()}, description=description)
    return ds


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """Two figures: ``<stem>-summary.png``, the inventories (slot types, read rate and slot
    efficiency against the population N, Wilson 95 % intervals over the runs pooled), and
    ``<stem>-capture.png``, two tags in one slot (the engine's capture trials, the batched
    capture sweep with Clopper-Pearson 95 % intervals, the RN16 acceptance trade-off).

    Drawn by :mod:`rfsim.scenarios._inventory_figures`.

    Parameters
    ----------
    dataset_path : pathlib.Path
        A dataset written by :func:`run`.
    out_dir : pathlib.Path
        Folder of the figures.

    Returns
    -------
    list of pathlib.Path
        The written figure files.
    """
    return _figures.plot(dataset_path, out_dir)
