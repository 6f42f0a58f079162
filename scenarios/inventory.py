"""Scenario ``inventory``: a reader inventories N tags at random positions in a room.

Every inventory runs the Gen2 Q algorithm (:mod:`rfsim.protocols.inventory`) at sample level through
the engine: the reader's PIE commands, every tag's power-up, PIE decoding and state machine,
the superposition of all RN16/EPC replies at the reader and its receiver. Collisions and
capture therefore emerge from the waveforms (gen2-and-validation-anchors.md §4.4–4.6).

Geometry: a rectangular room (floor at z = 0); tags uniformly inside it (margin 0.5 m),
heights uniform in ``tag_height_m``, vertical dipoles with a random azimuth; one to four
reader patch antennas in the middle of the walls at ``reader_height_m``, facing the room
centre, used in turn per round. Channel: Friis LoS, optional floor reflection (image method)
and the exponential APDP (PASS room curves), drawn per round and held within it.

Tables:

* ``slots``: one row per slot (see :data:`rfsim.protocols.inventory.SLOT_FIELDS`) with the population
  and run;
* ``reads``: one row per EPC read (:data:`rfsim.protocols.inventory.READ_FIELDS`), as the ``link``
  scenario's reads;
* ``inventories``: one row per inventory (tags read, slots, air time, efficiency);
* ``capture``: two tags in the same slot at different distances on the boresight of a
  patch; whether the reader read either EPC (capture), against the ratio of their
  backscatter powers at the reader. The replies of identical tags (same clock, same T1)
  are synchronous and share the preamble, so the receiver's gain estimate is h1 + h2 and a
  bit where the tags differ is decided by the sign of |h1|² − |h2|²: capture needs only a
  power ratio that the noise cannot mask, and fails when h1 + h2 ≈ 0 (the preamble
  cancels). The experiment therefore runs at a reduced SNR (``capture.noise_figure_db``).
* ``tags``: one row per tag of every inventory: position, orientation and the tag's own
  spread (``spread``, :mod:`rfsim.devices.tag_spread`: BLF error within FrT, T1 within
  [T1min, T1max], chip states, antenna yaw/roll; off by default, then zeros and the nominal
  T1). Tags with spread need ``reader.blf_search = "preamble"``.
* ``capture_sweep``, ``capture_trials``, ``acceptance`` (``capture_sweep``,
  :mod:`rfsim.scenarios._capture_sweep`): P(capture) against the modulated power ratio of two
  colliding RN16 replies, 0–15 dB, FM0 (``fm0-40k``) and Miller-4 (``miller4-320k``), with
  and without the tags' spread, ``capture_sweep.trials`` collisions per point with the
  Clopper–Pearson 95 % interval; the reader's BLF search and RN16 acceptance
  (:func:`rfsim.devices.reader.search_decode`, :func:`rfsim.devices.reader.rn16_threshold_db`) on a
  stacked array of RN16 windows; the false-ACK and missed-capture rates against the
  acceptance threshold on the same collisions.
* ``capture_inventories`` (``capture_inventory.enabled``, off by default): a population with
  spread in a 4 m × 3 m room (every tag powered) inventoried at sample level with capture,
  at sample level with capture switched off (:class:`NoCaptureAir`) and at protocol level:
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
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rfsim.devices.reader_config import ReaderConfig
from rfsim.devices.tag_config import TagConfig
from rfsim.devices.tag_spread import SPREAD_FIELDS, TagSpreadConfig, orientation_offsets_rad
from rfsim.scenarios import _capture_sweep as sweep
from rfsim.core.config import check_fields, param
from rfsim.core.errors import ConfigError
from rfsim.protocols.inventory import READ_FIELDS, SLOT_FIELDS, EngineAir, InventoryConfig, run_inventory
from rfsim.core.progress import track
from rfsim.core.rng import trial_rng
from rfsim.core.units import C_M_S
from rfsim.core.plots import figure_path, pyplot, save_figure
from rfsim.core.references import cite
from rfsim.core.lazy import lazy_import

_antennas = lazy_import("rfsim.channels.antennas")
_small_scale = lazy_import("rfsim.channels.small_scale")
_scene = lazy_import("rfsim.channels.scene")
_surfaces = lazy_import("rfsim.channels.surfaces")
_reader = lazy_import("rfsim.devices.reader")
_tag = lazy_import("rfsim.devices.tag")
_dataset = lazy_import("rfsim.core.dataset")
_link = lazy_import("rfsim.gen2.link")

NAME = "inventory"
DESCRIPTION = "Q-algorithm inventory of N tags in a room at sample level: slots, reads, capture"


@dataclass(frozen=True)
class RoomConfig:
    length_m: float = param(8.0, lo=2.0, hi=100.0, unit="m", doc="room extent along x")
    width_m: float = param(6.0, lo=2.0, hi=100.0, unit="m", doc="room extent along y")
    tag_height_m: tuple[float, float] = param((0.5, 1.5), lo=0.05, hi=10.0, unit="m", doc="tag height range")
    reader_height_m: float = param(1.5, lo=0.1, hi=10.0, unit="m", doc="reader antenna height")
    n_antennas: int = param(1, lo=1, hi=4, doc="reader antennas (middle of walls x=0, x=L, y=0, y=W)")
    reader_gain_dbi: float = param(6.0, lo=0.0, hi=15.0, unit="dBi", doc="patch peak gain")
    reader_beamwidth_deg: float = param(70.0, lo=20.0, hi=180.0, unit="deg", doc="patch beamwidth")
    floor: bool = param(True, doc="floor reflection (image method, concrete eps_r 5.3)")
    apdp: bool = param(True, doc="exponential APDP diffuse taps (PASS room curves)")

    def __post_init__(self):
        check_fields(self, "room")


@dataclass(frozen=True)
class CaptureConfig:
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


# ----------------------------------------------------------------------------- building blocks


def tag_epc_hex(template: str, k: int) -> str:
    """EPC of tag k: the template's length with the index in its last digits (unique EPCs)."""
    n = len(template.replace(" ", ""))
    return format(k + 1, f"0{n}X")[-n:]


def make_tags(config: TagConfig, antennas, *, seed: int, key: tuple[int, ...], spread: TagSpreadConfig | None = None,
              link=None, records: list | None = None) -> list:
    """One PassiveTag per antenna, tag k with its own stream ``trial_rng(seed, *key, k)``.

    With an enabled ``spread`` tag k draws its own BLF error, T1, chip states and antenna
    yaw/roll offsets on ``link`` from its spread sub-stream ``trial_rng(seed, *key, k, 0)``
    (:class:`rfsim.devices.tag_spread.TagSpreadConfig`); each draw is appended to ``records``.
    """
    from dataclasses import replace

    tags = []
    for k, a in enumerate(antennas):
        cfg = replace(config, epc_hex=tag_epc_hex(config.epc_hex, k))
        if spread is not None and spread.enabled:
            cfg, rec = spread.draw(cfg, link, rng=trial_rng(seed, *key, k, 0))
            off = orientation_offsets_rad(rec)
            a = replace(a, orientation=tuple(o + d for o, d in zip(a.orientation, off)))
            if records is not None:
                records.append(rec)
        tags.append(_tag.PassiveTag(cfg, a, rng=trial_rng(seed, *key, k)))
    return tags


def tag_antenna(position_m, azimuth_rad: float) -> _antennas.Antenna:
    """Vertical half-wave dipole tag at ``position_m`` facing ``azimuth_rad``."""
    return _antennas.Antenna(position_m=tuple(float(v) for v in position_m), orientation=(float(azimuth_rad), 0.0, 0.0),
                             pattern=_antennas.HalfWaveDipole(), polarization="linear", pol_tilt_rad=0.0)


def reader_antennas(room: RoomConfig) -> list[_antennas.Antenna]:
    """Patches in the middle of the walls x=0, x=L, y=0, y=W (in that order), facing inwards."""
    L, W, h = room.length_m, room.width_m, room.reader_height_m
    spots = [((0.0, W / 2, h), 0.0), ((L, W / 2, h), math.pi), ((L / 2, 0.0, h), math.pi / 2),
             ((L / 2, W, h), -math.pi / 2)]
    return [_antennas.Antenna(position_m=p, orientation=(yaw, 0.0, 0.0),
                              pattern=_antennas.Patch(room.reader_gain_dbi, room.reader_beamwidth_deg), polarization="circular")
            for p, yaw in spots[: room.n_antennas]]


def room_scene(room: RoomConfig) -> _scene.Scene:
    surfaces = (_surfaces.Surface(point_m=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), eps_r=5.3),) if room.floor else ()
    return _scene.Scene(surfaces=surfaces, apdp=_small_scale.ApdpModel() if room.apdp else None, image_order=1)


def random_tag_antennas(room: RoomConfig, n: int, *, rng: np.random.Generator) -> list[_antennas.Antenna]:
    """``n`` tags uniformly in the room (0.5 m from the walls), random azimuth."""
    x = rng.uniform(0.5, room.length_m - 0.5, n)
    y = rng.uniform(0.5, room.width_m - 0.5, n)
    z = rng.uniform(*room.tag_height_m, n)
    yaw = rng.uniform(-math.pi, math.pi, n)
    return [tag_antenna((x[k], y[k], z[k]), yaw[k]) for k in range(n)]


# ----------------------------------------------------------------------------- capture


CAPTURE_FIELDS = {
    "point": ("1", "index of the nominal power ratio"),
    "trial": ("1", "trial at this ratio"),
    "nominal_ratio_db": ("dB", "nominal backscatter power ratio near/far, 40·log10(d_far/d_near)"),
    "ratio_db": ("dB", "ratio from the incident CW powers: 2·(P_inc,near − P_inc,far) (monostatic)"),
    "far_m": ("m", "distance of the far tag (with a random sub-wavelength offset)"),
    "n_replies": ("1", "tags that replied with an RN16 in the slot"),
    "captured": ("1", "an EPC was read although both tags replied"),
    "captured_tag": ("1", "0 = near tag, 1 = far tag, -1 = none"),
}


def capture_trial(cfg: Config, far_m: float, *, seed: int, key: tuple[int, ...]) -> dict:
    """One Q = 0 slot with a near and a far tag on the reader's boresight; both reply."""
    from dataclasses import replace

    cap = cfg.capture
    h = cfg.room.reader_height_m
    reader_ant = _antennas.Antenna(position_m=(0.0, 0.0, h), orientation=(0.0, 0.0, 0.0),
                                   pattern=_antennas.Patch(cfg.room.reader_gain_dbi, cfg.room.reader_beamwidth_deg),
                                   polarization="circular")
    ants = [tag_antenna((cap.near_m, 0.0, h), math.pi), tag_antenna((far_m, 0.0, h), math.pi)]
    tags = make_tags(cfg.tag, ants, seed=seed, key=key + (0,))
    reader_cfg = replace(cfg.reader, noise_figure_db=cap.noise_figure_db)
    reader = _reader.Reader(reader_cfg, [reader_ant], rng=trial_rng(seed, *key, 1))
    air = EngineAir(reader, tags, _scene.Channel(_scene.Scene()), rng=trial_rng(seed, *key, 2), keep_exchanges=True)
    inv = InventoryConfig(q_mode="fixed", q_initial=0.0, max_rounds=1, session=cfg.inventory.session)
    log = run_inventory(air, inv)
    p_inc = air.exchanges[0].incident_power_dbm  # the Query
    tag = log.slots["tag"][0]
    return dict(ratio_db=2.0 * (p_inc[0] - p_inc[1]), far_m=far_m, n_replies=log.slots["n_replies"][0],
                captured=bool(tag >= 0 and log.slots["n_replies"][0] >= 2), captured_tag=tag)


def capture_table(cfg: Config, *, seed: int) -> dict[str, list]:
    """Capture probability data: for each nominal ratio, ``trials`` random-phase trials.

    The far tag sits at d_near·10^(r/40) plus a uniform offset in ±λ/4 (λ at 915 MHz): the
    round-trip phase difference 4π·Δd/λ then spans a full turn, so the relative phase of
    the two replies is random, as it is between real tags.
    """
    rows: dict[str, list] = {k: [] for k in CAPTURE_FIELDS}
    lam = C_M_S / 915e6
    for i, r_db in enumerate(track(cfg.capture.ratios_db, desc="capture", unit="ratios")):
        for j in range(cfg.capture.trials):
            key = (10**6 + i, j)
            off = trial_rng(seed, *key, 3).uniform(-lam / 4, lam / 4)
            far = cfg.capture.near_m * 10.0 ** (r_db / 40.0) + off
            out = capture_trial(cfg, far, seed=seed, key=key)
            for k, v in dict(point=i, trial=j, nominal_ratio_db=r_db, **out).items():
                rows[k].append(v)
    return rows


# ----------------------------------------------------------------------------- run


class NoCaptureAir:
    """A sample-level air interface whose reader never decodes a slot in which two or more
    tags replied (ground truth): capture switched off, the protocol level's collision rule
    (:class:`rfsim.protocols.inventory.ProtocolAir`) on otherwise identical waveforms. The slot is
    detected, not decoded, so the reader does not ACK and counts a collision."""

    def __init__(self, air):
        self.air, self.link = air, air.link

    def exchange(self, cmd, **kw):
        from dataclasses import replace

        ex = self.air.exchange(cmd, **kw)
        if len(ex.replied) >= 2 and ex.detected:
            return replace(ex, success=False, bits=None, failure_reason="collision")
        return ex


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
    ``trial_rng(seed, 3_000_000 + p, r, ...)`` as the main inventories."""
    from dataclasses import replace

    from rfsim.protocols.inventory import ProtocolAir

    ci, cs = config.capture_inventory, config.capture_sweep
    rows: dict[str, list] = {k: [] for k in CAPTURE_INVENTORY_FIELDS}
    reader_cfg = replace(config.reader, blf_search="preamble", rn16_false_accept=cs.rn16_false_accept)
    room = ci.room
    antennas = reader_antennas(room)
    plan = [(p, n, r, mode) for p, n in enumerate(ci.populations) for r in range(ci.runs)
            for mode in ("capture", "no-capture", "protocol")]
    for p, n, r, mode in track(plan, desc="inventories with capture on/off", unit="inventories"):
        key = (3_000_000 + p, r)
        reader = _reader.Reader(reader_cfg, antennas, rng=trial_rng(seed, *key, 1))
        tags = make_tags(config.tag, random_tag_antennas(room, n, rng=trial_rng(seed, *key, 0)), seed=seed,
                         key=key + (3,), spread=cs.spread, link=reader.link)
        if mode == "protocol":
            air = ProtocolAir(reader.link, tags)
        else:
            air = EngineAir(reader, tags, _scene.Channel(room_scene(room)), rng=trial_rng(seed, *key, 2),
                            keep_exchanges=True)
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
            tag_ants = random_tag_antennas(room, n, rng=trial_rng(seed, p, r, 0))
            reader = _reader.Reader(config.reader, antennas, rng=trial_rng(seed, p, r, 1))
            recs: list = []
            tags = make_tags(config.tag, tag_ants, seed=seed, key=(p, r, 3), spread=config.spread,
                             link=reader.link, records=recs)
            _tag_rows(tag_rows, n, r, tags, recs, _link.t1(reader.link).nom_s)
            air = EngineAir(reader, tags, _scene.Channel(room_scene(room)), rng=trial_rng(seed, p, r, 2))
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
    ds.add_table("slots", {k: _dataset.column(np.asarray(v), *(units.get(k) or SLOT_FIELDS[k])) for k, v in slots.items()},
                 description="one row per slot of every inventory: what the reader saw and what happened "
                             "(ground truth), the Q algorithm's state")
    ds.add_table("reads", {k: _dataset.column(np.asarray(v), *(units.get(k) or READ_FIELDS[k])) for k, v in reads.items()},
                 description="one row per EPC read (CRC ok): the reader's per-read report")
    ds.add_table("inventories", {k: _dataset.column(np.asarray(v), *INVENTORY_FIELDS[k]) for k, v in inv.items()},
                 description="one row per inventory (population, run): tags read, slots, air time, efficiency")
    ds.add_table("tags", {k: _dataset.column(np.asarray(v), *TAG_FIELDS[k]) for k, v in tag_rows.items()},
                 description="one row per tag of every inventory: position, antenna orientation and the tag's "
                             "own spread (BLF error, T1, chip states; zeros / nominal T1 without spread)")
    if config.capture_sweep.enabled:
        cs = config.capture_sweep
        rows, trials, accept = sweep.tables(cs, sweep.run_sweep(cs, seed=seed))
        ds.add_table("capture_sweep", {k: _dataset.column(np.asarray(v), *sweep.POINT_FIELDS[k]) for k, v in rows.items()},
                     description="one row per point (profile, spread, power ratio) of the batched two-tag capture "
                                 "sweep: P(capture) with its Clopper-Pearson interval, false ACKs")
        ds.add_table("capture_trials", {k: _dataset.column(np.asarray(v), *sweep.TRIAL_FIELDS[k]) for k, v in trials.items()},
                     description="one row per collision of the capture sweep: what the reader decoded, its "
                                 "acceptance statistic, the two tags' BLF errors and T1")
        ds.add_table("acceptance", {k: _dataset.column(np.asarray(v), *sweep.ACCEPT_FIELDS[k]) for k, v in accept.items()},
                     description="RN16 acceptance threshold against false-ACK and missed-capture rates over the "
                                 "collisions of the capture sweep (ratios pooled), per profile and spread")
    if config.capture_inventory.enabled:
        ci = capture_inventories(config, seed=seed)
        ds.add_table("capture_inventories", {k: _dataset.column(np.asarray(v), *CAPTURE_INVENTORY_FIELDS[k])
                                             for k, v in ci.items()},
                     description="one row per inventory of a population with spread, with capture on and off at "
                                 "sample level and at protocol level: slots and air time to read every tag")
    if config.capture.enabled:
        cap = capture_table(config, seed=seed)
        ds.add_table("capture", {k: _dataset.column(np.asarray(v), *CAPTURE_FIELDS[k]) for k, v in cap.items()},
                     description="one row per capture trial: two tags in one Q = 0 slot at a set backscatter power "
                                 "ratio; whether the reader still read an EPC")
    return ds


def capture_probability(ratio_db: np.ndarray, captured: np.ndarray, edges_db: np.ndarray):
    """Binned capture probability: (bin centres [dB], P(capture), trials per bin)."""
    idx = np.digitize(ratio_db, edges_db) - 1
    ok = (idx >= 0) & (idx < edges_db.size - 1)
    n = np.bincount(idx[ok], minlength=edges_db.size - 1)
    k = np.bincount(idx[ok], weights=captured[ok].astype(float), minlength=edges_db.size - 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return 0.5 * (edges_db[1:] + edges_db[:-1]), k / n, n


def _count_text(n: np.ndarray) -> str:
    """"20" or "18-20": the trial counts of the plotted points."""
    if not n.size:
        return "0"
    return f"{n.min()}" if n.min() == n.max() else f"{n.min()}-{n.max()}"


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """Slot types per population, read rate and efficiency vs N, capture probability."""
    plt = pyplot()
    import h5py

    from rfsim.core.dataset import read_table
    from rfsim.detection.fit import wilson_interval
    from rfsim.protocols.inventory import SLOT_TYPES

    s = read_table(dataset_path, "slots")
    inv = read_table(dataset_path, "inventories")
    with h5py.File(dataset_path, "r") as f:
        has_capture = "capture" in f
        has_sweep = "capture_sweep" in f
    pops = np.unique(inv["population"])
    fig, axes = plt.subplots(2, 3, figsize=(16, 8))
    _plot_sweep(axes[0, 2], axes[1, 2], dataset_path if has_sweep else None)
    a = axes[0, 0]
    bottom = np.zeros(pops.size)
    types = np.asarray(s["slot_type"]).astype(str)
    for st in SLOT_TYPES:
        frac = np.array([np.mean(types[s["population"] == n] == st) for n in pops])
        a.bar([str(n) for n in pops], frac, bottom=bottom, label=st)
        bottom += frac
    a.set_xlabel("tags N")
    a.set_ylabel("fraction of slots")
    a.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    a.set_title("slot types")
    a = axes[0, 1]
    a.plot(pops, [inv["read_rate"][inv["population"] == n].mean() for n in pops], marker="o")
    a.set_xlabel("tags N")
    a.set_ylabel("read rate (fraction of tags read)")
    a.set_ylim(-0.05, 1.05)
    a.grid(True, alpha=0.3)
    a = axes[1, 0]
    a.plot(pops, [inv["efficiency"][inv["population"] == n].mean() for n in pops], marker="o", label="slot efficiency")
    a.axhline(1 / math.e, color="k", ls=":", label="1/e")
    a.set_xlabel("tags N")
    a.set_ylabel("successful slots / slots")
    a.legend()
    a.grid(True, alpha=0.3)
    a = axes[1, 1]
    if has_capture:
        c = read_table(dataset_path, "capture")
        ok = np.isfinite(c["ratio_db"]) & (c["n_replies"] >= 2)
        pts = np.unique(c["point"][ok])
        # one marker per simulated nominal ratio, at the mean of its trials' measured ratios
        x = np.array([c["ratio_db"][ok & (c["point"] == i)].mean() for i in pts])
        n = np.array([np.sum(ok & (c["point"] == i)) for i in pts])
        k = np.array([np.sum(c["captured"][ok & (c["point"] == i)]) for i in pts])
        lo, hi = wilson_interval(k, n)
        pc = k / n
        a.errorbar(x, pc, yerr=np.vstack([pc - lo, hi - pc]), marker="o", capsize=3,
                   label=f"per simulated ratio, {_count_text(n)} trials each (Wilson 95 %)")
        a.plot(c["ratio_db"][ok], np.where(c["captured"][ok], 1.04, -0.04), "|",
               color="0.6", ms=6, label="trials (captured = 1)")
        a.set_ylim(-0.08, 1.08)
        a.legend(fontsize=8, loc="lower right")
    a.set_xlabel("backscatter power ratio near/far at the reader [dB]")
    a.set_ylabel("capture probability")
    a.set_title("two tags in one slot, engine (lock-step tags): capture", fontsize=10)
    a.grid(True, alpha=0.3)
    fig.suptitle(f"Inventory with the Q algorithm at sample level ({cite('gen2')}, Annex D)")
    fig.tight_layout()
    return [save_figure(fig, figure_path(dataset_path, out_dir, "summary"))]


def _plot_sweep(a, b, path) -> None:
    """P(capture) vs power ratio (Clopper-Pearson 95 %) and the acceptance trade-off."""
    from rfsim.core.dataset import read_table

    if path is None:
        for ax in (a, b):
            ax.text(0.5, 0.5, "capture sweep not run", ha="center", va="center", transform=ax.transAxes)
        return
    c = read_table(path, "capture_sweep")
    acc = read_table(path, "acceptance")
    prof = np.asarray(c["profile"]).astype(str)
    code = np.asarray(c["line_code"]).astype(str)
    for name in dict.fromkeys(prof):
        for sp in (0, 1):
            m = (prof == name) & (c["spread"] == sp)
            if not m.any():
                continue
            x, p = c["ratio_db"][m], c["p_capture"][m]
            a.errorbar(x, p, yerr=np.vstack([p - c["ci_lo"][m], c["ci_hi"][m] - p]), marker="o" if sp else "s",
                       ms=3, capsize=2, ls="-" if sp else "--",
                       label=f"{code[m][0]} ({name}), {'own BLF/T1' if sp else 'lock-step'}")
    n = int(c["trials"].min()) if len(c["trials"]) else 0
    gamma = float(c["threshold_db"][0]) if len(c["threshold_db"]) else math.nan
    a.set_xlabel("power ratio of the two replies at the reader [dB]")
    a.set_ylabel("P(capture): RN16 accepted and one tag's")
    a.set_title(f"capture sweep: {n} collisions/point, RN16 accepted at {gamma:.1f} dB", fontsize=10)
    a.set_ylim(-0.03, 1.03)
    a.grid(True, alpha=0.3)
    a.legend(fontsize=7, loc="lower right")
    aprof = np.asarray(acc["profile"]).astype(str)
    for name in dict.fromkeys(aprof):
        for sp in (0, 1):
            m = (aprof == name) & (acc["spread"] == sp)
            if m.any():
                b.plot(acc["false_ack_rate"][m], acc["missed_capture_rate"][m], marker=".", ls="-" if sp else "--",
                       label=f"{name}, {'own BLF/T1' if sp else 'lock-step'}")
    b.set_xscale("symlog", linthresh=1e-3)
    b.set_xlabel("false-ACK rate per collided slot (threshold swept)")
    b.set_ylabel("missed-capture rate")
    b.set_title("RN16 acceptance: threshold on Eb/(N0+I), 0-20 dB", fontsize=10)
    b.grid(True, alpha=0.3)
    b.legend(fontsize=7)
