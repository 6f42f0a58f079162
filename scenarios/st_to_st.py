"""Scenario ``st-to-st``: phase cancellation on an exciter-powered sense-a-tag (ST) to ST link,
single antenna vs simple combination vs receiving-path selection vs the ASK-PSK stamp
(auris-sense-a-tag.md §4.3 R5-1 "Fig. 5.8", §5; seed L5735-6060; wave2-specs.md §X).

Scene (L5998-6045): an RF exciter at the origin (CW only, ``exciter.eirp_dbm`` = 35.16 dBm =
3.28 W EIRP at 915 MHz by default, :class:`rfsim.devices.exciter.Exciter` behind a patch antenna with
boresight +x); a transmitting ST (its modulating antenna SA2, a vertical half-wave dipole) at
x = 1, 1.5, …, 7 m (13 cells); per cell and repetition ``positions_per_cell`` receiving
dual-antenna STs uniform in a disc of radius 0.5 m around it, each with a uniformly random
orientation of its λ/4 antenna pair. All at ``height_m``. Channel: Friis + the exponential APDP
with the PASS ST-room curves (as ``phase-cancellation``).

The exchange (sample level, one :func:`rfsim.air.step.propagate` step per cell and repetition): the
exciter emits CW; the transmitting ST (semi-passive, :class:`rfsim.devices.sense_a_tag.SenseATag`,
its front end first, then its own schedule: :class:`rfsim.devices.own_schedule.OwnSchedule`)
backscatters the frame of ch. 5 — the ASK-PSK stamp (``stamp_cycles`` subcarrier cycles
S1/S2, then S1/S3) followed by 10 × '0' in Miller-2 (TRext pilot and the Gen2 preamble for
synchronisation, L6011-6017) — through its three-state modulator S1 = Γ_B, S2 = Γ_A,
S3 = Γ_B·e^{jψ}, ψ = 180° (L5914-5923, L6017-6019; Γ_A, Γ_B the ST modulator's states,
A_s its structural mode, rfsim.devices.tag), re-radiating (A_s − Γ(t))·incident; every receiving antenna (SA1, SA2 of every position, one batched
receiver each) gets the exciter's direct CW plus the backscatter, with receiver noise
``noise.nf_db`` over fs when ``noise.enabled``. Links are drawn in bulk per (cell, repetition)
(:func:`rfsim.channels.bulk.draw_links`) and handed to the step per antenna pair.

Techniques (R3-5 and R5-1 definitions, as ``phase-cancellation``): a sample is *detectable*
when SA2 alone would see an envelope difference above the 5 mV threshold with the CW
synchronised to the backscatter (``detector_gain·||B1| − |B2||`` from the measured phasors of the
two ASK states); *detected* = the chain decodes the 10 zeros exactly: single = SA2 (path P2),
combination = the RF sum SA1 + SA2, selection = Algorithm 1 (P2, else P1 = SA1), stamp = the
ST decodes the ASK stamp on P2 and, when it reads '-', decodes the data on P1 instead of P2
(L5984-5990, L6019-6023); *cancelled* = detectable and not detected. Per cell and technique
the probability has a Clopper–Pearson 95 % interval. Closed forms (Eq. 3.4/3.21,
:func:`rfsim.devices.st_analytic.technique_outcomes`) from the phasors the step produced are stored
beside the sample-level outcomes.

Full run (``mc.full``, seed 1, 11 700 samples): P(cancel) single 17.7 % [17.0, 18.4],
combination 10.1 % [9.5, 10.6], selection 4.7 % [4.3, 5.1], stamp 5.2 % [4.8, 5.6] (Clopper–Pearson
95 %); the three dual-antenna techniques stay below single antenna in every cell (R5-1). The
probability rises with distance (selection: 0.2 % at 1 m, 10–11 % at 6.5–7 m): the ST's modulator
(semi-passive, fixed states Γ_A = 0, ``|Γ_B|`` = 0.84 with A_s = 1, rfsim.devices.tag) keeps nearly every
sample detectable to 7 m, and far away more of them sit just above the threshold, where the
null region covers more phases (median synchronised difference 9.7× the threshold at 1 m, 1.4×
at 7 m; single-antenna P(cancel) ≈ 30 % below 2× the threshold, ≈ 14 % above; as
``phase-cancellation`` with ``tag_states.model = "chip"``).

Stamp vs selection (R5-1: "differ by < 0.1 %", L6039-6052). Selection decodes P2 and falls back
to P1 when that fails; the stamp commits to a path before decoding, from the ASK stamp on P2, so it
can only lose: it keeps P2 whose data fail (``stamp_kept_p2_data_failed``) or leaves P2 whose data
decode (``stamp_left_p2_data_ok``), near the threshold (54 of 57 within 3 %), where P2's data decode
in 13–72 % of the samples (0.97–1.02× the threshold) and the default stamp rule reads '1' in 87–100 %.
Full run, seed 1: stamp − selection = +0.49 points (57 kept, 0 left). The stamp rule is the cause;
switched (full run, seed 1): ``stamp.ask_min_transitions`` 10 → +0.39, 11 → +0.32, 12 → +0.48
(9 kept, 47 left); ``stamp.ask_margin`` (the settled-half comparator of ``phase-cancellation`` at
(1 + margin)·threshold) 0 → +0.47, 0.03 (that scenario's) → +0.21, 0.05 → +0.15 (3 kept, 14
left), 0.06 → +0.18. No rule reaches 0.1: near the threshold P2's data decoding is not a function
of the level that a decision taken before it could read.

Randomness: (cell c, repetition r) uses ``trial_rng(seed, c, r, k)``: k = 0 positions and
orientations, 1 links, 2 receiver noise, 3 exciter phase noise, 4 the transmitting ST's own
stream. Results do not depend on the number of worker processes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from rfsim.devices.exciter import Exciter, ExciterConfig
from rfsim.devices.sense_a_tag_config import SenseATagConfig
from rfsim.devices.st_pair import ask_stamp_transitions, cell_probabilities
from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.core.monte_carlo import MonteCarloConfig, run_cells
from rfsim.core.rng import trial_rng
from rfsim.core.columns import unit_of
from rfsim.devices.own_schedule import FrameConfig, OwnSchedule, build_frame
from rfsim.devices.st_rows import RowsChain
from rfsim.scenes.exciter import NoiseConfig, check_exciter_on, exciter_antenna, room, uniform_disc
from rfsim.scenes.links import BatchAntenna, BatchLink, DrawnLinks
from rfsim.core.lazy import lazy_import

_antennas = lazy_import("rfsim.channels.antennas")
_bulk = lazy_import("rfsim.channels.bulk")
sa = lazy_import("rfsim.devices.st_analytic")
_sense_a_tag = lazy_import("rfsim.devices.sense_a_tag")
_air = lazy_import("rfsim.air.step")
_dataset = lazy_import("rfsim.core.dataset")
_figures = lazy_import("rfsim.scenarios._st_to_st_figures")

NAME = "st-to-st"
DESCRIPTION = ("exciter-powered ST-to-ST link (Fig. 5.8): P(cancel) per cell for single antenna, combination, "
               "path selection and the ASK-PSK stamp")

TECHS = ("single", "combination", "selection", "stamp")
V_PER_SQRT_W = math.sqrt(2.0 * 50.0)  # RF peak volts per √W at the 50 Ω detector (rfsim.devices.st_receiver)


@dataclass(frozen=True)
class GeometryConfig:
    """Placement of the exciter and the STs, the exciter's antenna, and the channel's small scale.

    Attributes
    ----------
    st_x_m : tuple of float, default (1.0, 1.5, ..., 7.0)
        Transmitting-ST x positions (cells); exciter at the origin [m], in [0.2, 100].
    disc_radius_m : float, default 0.5
        Receiving STs uniform in this disc [m], in [0.01, 5].
    height_m : float, default 1.0
        Height of exciter and STs [m], in [0.1, 10].
    exciter_antenna : {"patch", "dipole"}, default "patch"
        Patch (boresight +x) or vertical dipole.
    exciter_gain_dbi : float, default 6.0
        Patch peak gain [dBi], in [0, 15].
    apdp : bool, default True
        Exponential APDP small scale (PASS ST-room curves).
    """

    st_x_m: tuple[float, ...] = param(tuple(1.0 + 0.5 * i for i in range(13)), lo=0.2, hi=100.0, unit="m",
                                      doc="transmitting-ST x positions (cells); exciter at the origin")
    disc_radius_m: float = param(0.5, lo=0.01, hi=5.0, unit="m", doc="receiving STs uniform in this disc")
    height_m: float = param(1.0, lo=0.1, hi=10.0, unit="m", doc="height of exciter and STs")
    exciter_antenna: Literal["patch", "dipole"] = param("patch", doc="patch (boresight +x) or vertical dipole")
    exciter_gain_dbi: float = param(6.0, lo=0.0, hi=15.0, unit="dBi", doc="patch peak gain")
    apdp: bool = param(True, doc="exponential APDP small scale (PASS ST-room curves)")


@dataclass(frozen=True)
class StampConfig:
    """The ASK-PSK stamp, the payload and the stamp decision rule (AURIS ch. 5, L5914–L5990).

    Attributes
    ----------
    stamp_cycles : int, default 8
        Subcarrier cycles of each stamp part (ASK, then PSK), in [1, 64].
    psi_deg : float, default 180.0
        PSK state separation ψ (source: ideally 180°) [deg], in [1, 180].
    zero_bits : int, default 10
        Data bits '0' after the stamp (source: 10), in [1, 256].
    ask_min_transitions : int, default 0
        Comparator transitions in the ASK stamp that decode as '1' (0 = one per
        subcarrier cycle, half of an undisturbed stamp), in [0, 2 × stamp_cycles].
    ask_margin : float, default 0.0
        > 0: the ASK stamp is '1' when a comparator at (1 + margin)*threshold follows
        all but one transition of its settled half
        (rfsim.devices.st_pair.ask_stamp_transitions; phase-cancellation: 0.03),
        overriding ask_min_transitions, in [0, 1].
    """

    stamp_cycles: int = param(8, lo=1, hi=64, doc="subcarrier cycles of each stamp part (ASK, then PSK)")
    psi_deg: float = param(180.0, lo=1.0, hi=180.0, unit="deg", doc="PSK state separation ψ (source: ideally 180°)")
    zero_bits: int = param(10, lo=1, hi=256, doc="data bits '0' after the stamp (source: 10)")
    ask_min_transitions: int = param(0, lo=0, hi=1000,
                                     doc="comparator transitions in the ASK stamp that decode as '1' (0 = one per "
                                         "subcarrier cycle, half of an undisturbed stamp)")

    ask_margin: float = param(0.0, lo=0.0, hi=1.0, doc="> 0: the ASK stamp is '1' when a comparator at (1 + margin)"
                              "*threshold follows all but one transition of its settled half (rfsim.devices.st_pair."
                              "ask_stamp_transitions; phase-cancellation: 0.03), overriding ask_min_transitions")

    def __post_init__(self):
        if self.ask_min_transitions > 2 * self.stamp_cycles:
            raise ConfigError("stamp.ask_min_transitions", self.ask_min_transitions,
                              f"0 … 2 x stamp.stamp_cycles = {2 * self.stamp_cycles} (the transitions of the stamp)")


def _tx_default() -> SenseATagConfig:
    return SenseATagConfig(st_id=0x5458, n_antennas=1, technique="single")


@dataclass(frozen=True)
class Config:
    """Configuration of the ``st-to-st`` scenario.

    Checked on construction: at least one cell, a dual-antenna receiving ST, a single-antenna
    transmitting ST, a valid frame, and an exciter schedule that is on during the frame.

    Attributes
    ----------
    mc : rfsim.core.monte_carlo.MonteCarloConfig
        Monte Carlo size.
    geometry : GeometryConfig
        Placement and channel.
    exciter : rfsim.devices.exciter.ExciterConfig
        RF exciter (CW).
    frame : rfsim.devices.own_schedule.FrameConfig
        The transmitting ST's frame (sample rate, BLF, line code).
    stamp : StampConfig
        ASK-PSK stamp and payload.
    tx_st : rfsim.devices.sense_a_tag_config.SenseATagConfig
        Transmitting ST (its modulator).
    st : rfsim.devices.sense_a_tag_config.SenseATagConfig
        Receiving ST (threshold, detector gain, spacing).
    noise : rfsim.scenes.exciter.NoiseConfig
        Receiver noise (off: the 5 mV threshold decides, as in the source).
    """

    mc: MonteCarloConfig = param(MonteCarloConfig(), doc="Monte Carlo size")
    geometry: GeometryConfig = param(GeometryConfig(), doc="placement and channel")
    exciter: ExciterConfig = param(ExciterConfig(), doc="RF exciter (CW)")
    frame: FrameConfig = param(FrameConfig(), doc="the transmitting ST's frame (sample rate, BLF, line code)")
    stamp: StampConfig = param(StampConfig(), doc="ASK-PSK stamp and payload")
    tx_st: SenseATagConfig = param(_tx_default(), doc="transmitting ST (its modulator)")
    st: SenseATagConfig = param(SenseATagConfig(), doc="receiving ST (threshold, detector gain, spacing)")
    noise: NoiseConfig = param(NoiseConfig(enabled=False), doc="receiver noise (off: the 5 mV threshold decides, "
                                                                 "as in the source)")

    def __post_init__(self):
        if len(self.geometry.st_x_m) == 0:
            raise ConfigError("geometry.st_x_m", self.geometry.st_x_m, "at least one cell")
        if self.st.n_antennas != 2:
            raise ConfigError("st.n_antennas", self.st.n_antennas, "2 (the techniques compare SA1 and SA2)")
        if self.tx_st.n_antennas != 1:
            raise ConfigError("tx_st.n_antennas", self.tx_st.n_antennas, "1 (the modulating antenna SA2)")
        self.frame.check("frame")
        if self.exciter.schedule_s:
            frame = build_frame(payload(self), self.frame, stamp_cycles=self.stamp.stamp_cycles)
            check_exciter_on(self.exciter, fs_hz=self.frame.fs_hz, n_samples=frame.n_samples)


# ----------------------------------------------------------------------------- one (cell, repetition)


def payload(config: Config) -> np.ndarray:
    """The data bits after the stamp: ``stamp.zero_bits`` zeros (the source's 10 × '0').

    Parameters
    ----------
    config : Config
        Scenario configuration (``stamp.zero_bits``).

    Returns
    -------
    ndarray of uint8, shape (zero_bits,)
        All zeros.
    """
    return np.zeros(config.stamp.zero_bits, dtype=np.uint8)


def simulate_cell(config: Config, cell: int, rep: int, seed: int) -> dict[str, np.ndarray]:
    """One air step for all receiving-ST positions of (cell, repetition); the columns of the
    ``samples`` table.

    Parameters
    ----------
    config : Config
        Scenario configuration.
    cell : int
        Cell index into ``geometry.st_x_m``.
    rep : int
        Repetition of the cell.
    seed : int
        Root seed; the cell uses ``trial_rng(seed, cell, rep, k)`` (module docstring).

    Returns
    -------
    dict of str to ndarray, shape (n_positions,)
        The columns of :func:`st_outcomes` plus cell, repetition, transmitting-ST x [m],
        receiving-ST centre [m] and orientation [rad], antenna positions [m] and the CW
        power incident at the transmitting ST [W].
    """
    g, fr, mc = config.geometry, config.frame, config.mc
    n = mc.n_positions
    frame = build_frame(payload(config), fr, stamp_cycles=config.stamp.stamp_cycles)
    # devices
    ex_ant = exciter_antenna(g.exciter_antenna, g.exciter_gain_dbi, g.height_m)
    exciter = Exciter(config.exciter, ex_ant, rng=trial_rng(seed, cell, rep, 3))
    tx_pos = np.array([g.st_x_m[cell], 0.0, g.height_m])
    tx_ant = _antennas.vertical_dipole(tx_pos)
    st_tx = _sense_a_tag.SenseATag(config.tx_st, [tx_ant], rng=trial_rng(seed, cell, rep, 4), fs_hz=fr.fs_hz)
    tx = OwnSchedule(st_tx, frame, psi_rad=math.radians(config.stamp.psi_deg))
    # receiving STs: centres in the disc, random orientation of the λ/4 pair
    prng = trial_rng(seed, cell, rep, 0)
    dx, dy = uniform_disc(prng, n, g.disc_radius_m)
    orient = prng.uniform(-np.pi, np.pi, n)
    centres = tx_pos + np.stack([dx, dy, np.zeros(n)], axis=1)
    sa_pos = _sense_a_tag.st_antenna_positions(centres, n_antennas=2, spacing_m=config.st.spacing_m, orientation_rad=orient)
    template = _antennas.vertical_dipole(np.zeros(3))
    sa = [BatchAntenna(template, sa_pos[:, j]) for j in range(2)]
    # links, drawn in bulk: exciter → tx ST, then per antenna exciter → SA and tx ST → SA
    lrng = trial_rng(seed, cell, rep, 1)
    sc, fc = room(g.apdp), config.exciter.fc_hz
    links = DrawnLinks()
    links.add(ex_ant, tx_ant, _bulk.draw_links(sc, ex_ant.position_m, tx_pos, fc_hz=fc, rng=lrng, tx_antenna=ex_ant,
                                               rx_antenna=tx_ant).pathset(0))
    for a in sa:
        links.add(ex_ant, a, BatchLink(_bulk.draw_links(sc, ex_ant.position_m, a.positions_m, fc_hz=fc, rng=lrng,
                                                        tx_antenna=ex_ant, rx_antenna=template)))
        links.add(tx_ant, a, BatchLink(_bulk.draw_links(sc, tx_pos, a.positions_m, fc_hz=fc, rng=lrng,
                                                        tx_antenna=tx_ant, rx_antenna=template)))
    noise_w = config.noise.power_w(fr.fs_hz)
    air = _air.propagate([exciter], [tx], [_air.AntennaPort(a, noise_power_w=noise_w) for a in sa], links, t0_s=0.0,
                    fs_hz=fr.fs_hz, n_samples=frame.n_samples, rng=trial_rng(seed, cell, rep, 2),
                    bandwidth_hz=2.0 * fr.blf_hz, decide=False, keep_components=True)
    incident_w = float(np.mean(np.abs(air.incident[0].samples) ** 2))
    phasors = [_phasors(frame, air, k) for k in range(2)]
    inputs = [a.samples for a in air.inputs]
    air = None  # its direct and backscatter parts, (n, samples) each, are not needed past the phasors
    out = st_outcomes(config, frame, phasors, inputs)
    out.update(cell=np.full(n, cell), repetition=np.full(n, rep), tx_x_m=np.full(n, tx_pos[0]),
               st_x_m=centres[:, 0], st_y_m=centres[:, 1], orientation_rad=orient,
               tx_incident_power_w=np.full(n, incident_w))
    for j, name in enumerate(("sa1", "sa2")):
        out[f"{name}_x_m"], out[f"{name}_y_m"] = sa_pos[:, j, 0], sa_pos[:, j, 1]
    return out


def _phasors(frame, air, k: int):
    """CW and the two ASK-state backscatter phasors at receiver k [V, 50 Ω peak], (n,) each,
    read from the step's components at settled samples of the reply (states S1 and S2)."""
    lv = frame.stamp.levels
    i1 = int(np.flatnonzero(lv > 0)[-1])
    i2 = int(np.flatnonzero(lv < 0)[-1])
    direct = air.direct[k]
    back = air.backscatter[0][k]
    return (V_PER_SQRT_W * direct[:, i1], V_PER_SQRT_W * back[:, i1], V_PER_SQRT_W * back[:, i2])


def st_outcomes(config: Config, frame, ph, inputs) -> dict[str, np.ndarray]:
    """Sample-level techniques on the step's inputs and the closed forms from its phasors.

    Single = P2 (SA2), combination = the RF sum SA1 + SA2, selection = Algorithm 1 (P2, else
    P1), stamp = the ASK stamp on P2 chooses P2 or P1 before decoding (module docstring).

    Parameters
    ----------
    config : Config
        Scenario configuration (``st``, ``frame``, ``stamp``).
    frame : rfsim.devices.own_schedule.Frame
        The transmitted frame (stamp, then the zeros), as built by
        :func:`rfsim.devices.own_schedule.build_frame`.
    ph : sequence of two tuples of three ndarray, each shape (n,)
        Per receiving antenna (SA1, SA2): the CW and the two ASK-state backscatter phasors
        [V, 50 Ω RF peak].
    inputs : sequence of two ndarray, each shape (n, n_samples)
        Per receiving antenna (SA1, SA2): its complex baseband input [√W].

    Returns
    -------
    dict of str to ndarray, shape (n,)
        Per antenna A_R, A_T1, A_T2, θ [V, rad]; ``sync_sa2_v``; closed-form and
        sample-level envelope differences [V]; ``detectable``; per technique
        ``detected_*``, ``cancelled_*``, ``closed_cancelled_*``; the stamp symbols on P2
        and the decodes of P1 and P2.
    """
    st, fr = config.st, config.frame
    rx = _sense_a_tag.make_receiver(st, fs_hz=fr.fs_hz, blf_hz=fr.blf_hz, m=fr.m, trext=fr.trext)
    out: dict[str, np.ndarray] = {}
    for (cw, b1, b2), name in zip(ph, ("sa1", "sa2")):
        out[f"a_r_{name}_v"], out[f"a_t1_{name}_v"], out[f"a_t2_{name}_v"] = np.abs(cw), np.abs(b1), np.abs(b2)
        out[f"theta_{name}_rad"] = np.angle(b1 * np.conj(cw))
    closed = sa.technique_outcomes(*ph[0], *ph[1], detector_gain=st.detector_gain, threshold_v=st.threshold_v)
    out["sync_sa2_v"] = closed.sync_sa2_v
    for key in ("sa1", "sa2", "combined"):
        out[f"closed_diff_{key}_v"] = getattr(closed, f"diff_{key}_v")
    detectable = closed.sync_sa2_v > st.threshold_v
    out["detectable"] = detectable
    x1, x2 = inputs
    # one chain at a time: each is four (n, samples) arrays, the largest of the step's memory
    ch = RowsChain.run(rx, x2)
    diff_sa2, p2 = ch.level_difference_v(rx, frame), ch.decoded(rx, frame)
    ask, psk = ch.stamp_symbols(rx, frame, config.stamp.ask_min_transitions)
    if config.stamp.ask_margin > 0:
        thr = (1 + config.stamp.ask_margin) * st.threshold_v
        ask = ask_stamp_transitions(ch.bandpassed_v, frame.stamp, thr) >= config.stamp.stamp_cycles - 1
    ch = None
    ch = RowsChain.run(rx, x1)
    # P1 decides only where P2 failed (Algorithm 1) or the stamp switched to it
    diff_sa1, p1 = ch.level_difference_v(rx, frame), ch.decoded(rx, frame, rows=~p2 | ~ask)
    ch = None
    ch = RowsChain.run(rx, x1 + x2)
    out["diff_sa2_v"], out["diff_sa1_v"], out["diff_combined_v"] = diff_sa2, diff_sa1, ch.level_difference_v(rx, frame)
    out["detected_single"] = p2
    out["detected_combination"] = ch.decoded(rx, frame)
    ch = None
    out["detected_selection"] = sa.select_detected(p1, p2)
    out["detected_stamp"] = np.where(ask, p2, p1)
    out["stamp_ask_sa2"], out["stamp_psk_sa2"] = ask, psk
    out["decoded_p2"] = p2
    out["decoded_p1"] = p1  # attempted only where P2 failed or the stamp chose P1 (False elsewhere)
    for t in TECHS:
        out[f"cancelled_{t}"] = detectable & ~out[f"detected_{t}"]
        out[f"closed_cancelled_{t}"] = getattr(closed, f"cancelled_{t}")
    return out


def monte_carlo(config: Config, *, seed: int) -> dict[str, np.ndarray]:
    """Every (cell, repetition) on ``config.mc.workers`` processes, concatenated in task order.

    Parameters
    ----------
    config : Config
        Scenario configuration (``mc`` sets the size and the workers).
    seed : int
        Root seed.

    Returns
    -------
    dict of str to ndarray
        The columns of :func:`simulate_cell` for every (cell, repetition), cells outer.
    """
    return run_cells(simulate_cell, config, len(config.geometry.st_x_m), config.mc, seed=seed)


# ----------------------------------------------------------------------------- run


def cell_table(samples, x_m) -> dict[str, np.ndarray]:
    """Per cell: P(cancel) per technique with Clopper–Pearson bounds, detectable fraction, n.

    Parameters
    ----------
    samples : dict of str to ndarray
        The per-position columns of :func:`monte_carlo`.
    x_m : sequence of float
        Transmitting-ST x of each cell [m].

    Returns
    -------
    dict of str to ndarray, shape (n_cells,)
        ``cell``, ``tx_x_m`` [m], per technique ``p_<technique>`` with its Clopper–Pearson
        95 % bounds and the sample count (:func:`rfsim.devices.st_pair.cell_probabilities`),
        ``detectable_fraction`` and ``median_tx_incident_power_w`` [W].
    """
    n_cells = len(x_m)
    out = {"cell": np.arange(n_cells), "tx_x_m": np.asarray(x_m, float)}
    cell = samples["cell"]
    out.update(cell_probabilities({t: samples[f"cancelled_{t}"] for t in TECHS}, cell, n_cells))
    out["detectable_fraction"] = np.array([samples["detectable"][cell == c].mean() for c in range(n_cells)])
    out["median_tx_incident_power_w"] = np.array([np.median(samples["tx_incident_power_w"][cell == c])
                                                  for c in range(n_cells)])
    return out


def stamp_vs_selection(samples) -> dict[str, float | int]:
    """Where stamp and selection disagree, and why (module docstring).

    Parameters
    ----------
    samples : dict of str to ndarray
        The per-position columns of :func:`monte_carlo`.

    Returns
    -------
    dict
        ``stamp_minus_selection`` (difference of the overall P(cancel), as a fraction),
        ``stamp_kept_p2_data_failed`` (detectable samples where the stamp kept P2, its data
        failed and P1 would decode), ``stamp_left_p2_data_ok`` (where it left P2 although
        its data decoded and P1 failed) and ``stamp_selection_samples``.
    """
    det = samples["detectable"]
    ask, p1, p2 = samples["stamp_ask_sa2"], samples["decoded_p1"], samples["decoded_p2"]
    n = det.size
    kept = det & ask & ~p2 & p1        # stamp keeps P2, its data fails, P1 would decode
    left = det & ~ask & p2 & ~p1       # stamp leaves P2 although its data decodes, P1 fails
    diff = samples["cancelled_stamp"].mean() - samples["cancelled_selection"].mean()
    return {"stamp_minus_selection": float(diff), "stamp_kept_p2_data_failed": int(kept.sum()),
            "stamp_left_p2_data_ok": int(left.sum()), "stamp_selection_samples": int(n)}


def run(config: Config, *, seed: int) -> _dataset.Dataset:
    """Simulate phase cancellation on the exciter-powered ST-to-ST link, per cell and technique.

    Reproduces AURIS Fig. 5.8 (auris-sense-a-tag.md §4.3 R5-1, §5; seed L5735–6060): the Monte
    Carlo over cells and repetitions (:func:`monte_carlo`), one sample-level air step each.

    Parameters
    ----------
    config : Config
        Scenario configuration.
    seed : int
        Root seed (the streams of the module docstring).

    Returns
    -------
    rfsim.core.dataset.Dataset
        Tables ``samples`` (one row per receiving-ST position: geometry, phasors,
        envelope differences, detection and cancellation per technique) and ``cells`` (per
        cell: P(cancel) per technique with Clopper–Pearson 95 % intervals, detectable
        fraction, median incident power [W]); root attributes with the overall
        probabilities and intervals, :func:`stamp_vs_selection`, the exciter EIRP [W] and
        carrier [Hz], the noise power [W] and the deviations from the source.
    """
    samples = monte_carlo(config, seed=seed)
    ds = _dataset.Dataset(title="exciter-powered ST-to-ST phase cancellation (AURIS Fig. 5.8)")
    ds.add_table("samples", {k: _dataset.column(v, unit_of(k), _describe(k)) for k, v in samples.items()},
                 description=_GROUPS["samples"])
    cells = cell_table(samples, config.geometry.st_x_m)
    ds.add_table("cells", {k: _dataset.column(v, unit_of(k), _describe(k)) for k, v in cells.items()},
                 description=_GROUPS["cells"])
    for t in TECHS:
        p, lo, hi, _ = sa.cancellation_probability(samples[f"cancelled_{t}"])
        ds.attrs[f"overall_p_{t}"] = float(p)
        ds.attrs[f"overall_ci_{t}"] = [float(lo), float(hi)]
    ds.attrs.update(stamp_vs_selection(samples))
    ds.attrs["exciter_eirp_w"] = float(10.0 ** ((config.exciter.eirp_dbm - 30.0) / 10.0))
    ds.attrs["exciter_fc_hz"] = float(config.exciter.fc_hz)
    ds.attrs["noise_power_w"] = config.noise.power_w(config.frame.fs_hz)
    ds.attrs["deviations"] = (
        "frame keeps the Gen2 TRext pilot and preamble after the stamp (synchronisation of the 10 zeros); "
        "stamp before the pilot, 8 + 8 subcarrier cycles (Fig. 5.7 format not in the text); transmitting ST "
        "modulator states from its tag front end (S1 = Gamma_B, S2 = Gamma_A, S3 = Gamma_B e^{j psi}) with its "
        "structural mode; exciter antenna a 6 dBi patch (not given by the source); one air step per cell and "
        "repetition with its own channel draw; stamp vs selection (source < 0.1 %): the stamp decides before decoding "
        "and can only lose, +0.49 points (full run, seed 1), +0.15 with stamp.ask_margin = 0.05, no rule reaches 0.1")
    return ds


_ANTENNAS = {"sa1": "SA1 (receive-only path P1)", "sa2": "SA2 (full ST path P2)", "combined": "SA1+SA2 RF sum"}
_KINDS = (("diff_", "sample-level envelope-detector difference |A(+1)-A(-1)| over the data"),
          ("closed_", "closed form (Eq. 3.4/3.21, R3-5) from the step's phasors"),
          ("p_", "probability of phase cancellation (R3-5)"), ("ci_", "Clopper-Pearson 95% bound"),
          ("detected_", "the chain decoded the 10 zeros exactly"),
          ("cancelled_", "detectable and not detected (R3-5)"),
          ("stamp_", "ASK-PSK stamp symbol decoded on P2 (True = '1', False = '-')"))


#: Columns whose meaning is not spelled out by the generic rules below.
_TEXT = {
    "cell": "index of the cell: position of the transmitting ST along x (geometry.st_x_m)",
    "repetition": "repetition of the cell (independent channel draw and receiving-ST positions)",
    "tx_x_m": "x of the transmitting ST (the exciter is at the origin)",
    "st_x_m": "x of the receiving ST's centre (uniform in a disc around the transmitting ST)",
    "st_y_m": "y of the receiving ST's centre (uniform in a disc around the transmitting ST)",
    "orientation_rad": "azimuth of the receiving ST's antenna pair (SA1 -> SA2), uniform in [0, 2 pi)",
    "tx_incident_power_w": "exciter CW power incident at the transmitting ST's antenna port",
    "median_tx_incident_power_w": "median over the cell of the exciter CW power incident at the transmitting ST",
    "detectable": "the synchronised envelope difference exceeds the comparator threshold on at least one path",
    "decoded_p1": "the receive-only path P1 (SA1) decoded the 10 zeros exactly",
    "decoded_p2": "the full ST path P2 (SA2) decoded the 10 zeros exactly",
    "detectable_fraction": "fraction of the cell's samples that are detectable",
    "n_samples": "number of receiving-ST samples in the cell",
}

#: Description of each table.
_GROUPS = {
    "samples": "one row per receiving-ST position: geometry, the step's phasors, sample-level and closed-form "
               "envelope differences, detection and cancellation per technique",
    "cells": "one row per transmitting-ST position: P(phase cancellation) per technique with Clopper-Pearson "
             "95 % intervals, detectable fraction, median incident power",
}


def _describe(key: str) -> str:
    if key in _TEXT:
        return _TEXT[key]
    text = key
    for short, long in _ANTENNAS.items():
        text = text.replace(short, long)
    kind = next((k for prefix, k in _KINDS if key.startswith(prefix)), None)
    return f"{kind}: {text}" if kind else text.replace("_", " ")


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """Fig. 5.8: P(phase cancellation) vs transmitting-ST distance per technique, the techniques'
    Clopper-Pearson intervals side by side at each distance.

    Drawn by :mod:`rfsim.scenarios._st_to_st_figures`.

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
    return _figures.plot(dataset_path, out_dir, techniques=TECHS)


__all__ = ["NAME", "DESCRIPTION", "Config", "run", "plot", "TECHS", "simulate_cell", "st_outcomes", "cell_table"]
