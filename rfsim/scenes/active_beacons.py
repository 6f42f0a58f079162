"""Active beacon tags and readers in a room at sample level: the beacons of a localization run
(Özkaya's active-RFID study; the ``rss_model = "waveform"`` mode of ``rss-localization``).

The statistical draws of the log-distance mode (:func:`rfsim.scenes.rss_rooms.draw_beacons`: the
same truth, quasi-static shadowing and people term, so that the two modes are paired trial by
trial) fix the large-scale received
power of every tag → reader link and beacon, Pr_j = α_j − 10·n_j·log10 d_j − nW·WAF + X_j + P_j
(rfsim.channels.rss). The waveform stage then sends the beacons physically:

* per beacon epoch (1 s) and tag i a scene whose walls are the floor plan's (WAF per
  crossing) and whose large scale is per reader (rfsim.channels.LinkLargeScale, ``by_antenna``):
  tag i → reader j is a ``LogDistance(n_j, 1 m, pl_d0 = P_t − α_j − X_ij − P_ij)``, so the
  channel's LoS power is exactly that Pr_j; tag ↔ tag links (listen-before-talk) are Friis
  through the walls. A target standing on a reference tag's spot (the home plan's fixed
  points (5, 2) and (7, 2)) is lifted 0.1 m (two antennas cannot share a point; its pl_d0
  absorbs the 3-D distance change, so its Pr_j is unchanged); optionally the
  exponential APDP (``waveform.apdp``: PASS room curves, taps redrawn every epoch — people
  moving) adds small-scale fading on top;
* every tag (the target and the reference tags) is a ``rfsim.devices.ActiveTag`` (Manchester MSK,
  5 dBm, 868 MHz, its own schedule phase in the 1 s period and ±``jitter_s``), every reader
  a ``rfsim.devices.ActiveReader`` (540 kHz filter, discriminator, CRC, RSSI over the frame,
  1 dB steps, −90 dBm floor); ``rfsim.protocols.beacons.run_beacons`` runs listen-before-talk,
  collisions and one air step per burst cluster;
* the reported RSSI of beacon (epoch t, tag i, reader j) is the reader's report of the frame
  with tag i's ID and sequence number t; a lost beacon (collision, CRC, below the floor) is
  NaN, which the estimators leave out.

The home preset's fingerprint survey (40 reads per cell) stays statistical: it is an offline
training campaign, not part of the localization run. Randomness: trial b of case c uses
``trial_rng(seed, c, 2, b)`` for the tags' schedules and phases, the receiver noise and the
APDP taps.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.core.rng import trial_rng
from rfsim.core.lazy import lazy_import

_antennas = lazy_import("rfsim.channels.antennas")
_small_scale = lazy_import("rfsim.channels.small_scale")
_scene = lazy_import("rfsim.channels.scene")
_large_scale = lazy_import("rfsim.channels.large_scale")
_active_reader = lazy_import("rfsim.devices.active_reader")
_active_tag = lazy_import("rfsim.devices.active_tag")
_rss_reader = lazy_import("rfsim.devices.rss_reader")
_air = lazy_import("rfsim.air.step")
_beacons = lazy_import("rfsim.protocols.beacons")

#: Tag transmit power [dBm] (L957).
TX_POWER_DBM = 5.0
#: A target closer than this [m] to a reference tag (in the plan) is lifted by SAME_SPOT_LIFT_M.
SAME_SPOT_M = 0.01
SAME_SPOT_LIFT_M = 0.1
#: Beacon chip rate [Hz] ("250 kbaud", L1770).
CHIP_RATE_HZ = 250e3


@dataclass(frozen=True)
class WaveformConfig:
    """Sample-level beacon settings of ``rss_model = "waveform"``."""

    fs_hz: float = param(2e6, lo=1e6, hi=2e7, unit="Hz", doc="sample rate (an integer multiple ≥ 4 of 250 kHz)")
    noise_figure_db: float = param(10.0, lo=0.0, hi=40.0, unit="dB", doc="reader noise figure")
    jitter_s: float = param(0.01, lo=0.0, hi=0.4, unit="s", doc="± jitter of each beacon time")
    lbt_listen_s: float = param(0.2e-3, lo=0.0, hi=0.1, unit="s", doc="listen-before-talk window (0 = off)")
    apdp: bool = param(False, doc="add exponential-APDP small-scale fading (PASS room curves), redrawn per epoch")

    def __post_init__(self):
        sps = self.fs_hz / CHIP_RATE_HZ
        if abs(sps - round(sps)) > 1e-9:
            raise ConfigError("waveform.fs_hz", self.fs_hz, f"an integer multiple of the {CHIP_RATE_HZ:g} Hz chip rate")


@dataclass
class WaveformStats:
    """Counts over a case: beacons due, dropped by LBT, collided; frames decoded; air steps.

    Attributes
    ----------
    due : int
        Beacons due (every tag, trial and epoch).
    dropped : int
        Beacons dropped by listen-before-talk.
    collided : int
        Beacons that overlapped another tag's beacon.
    decoded : int
        Frames with a valid CRC, summed over the readers.
    reported : int
        Decoded frames of the right epoch reported above the reader floor.
    air_steps : int
        Air-interface steps run (reception clusters and carrier sensing).
    """

    due: int = 0
    dropped: int = 0
    collided: int = 0
    decoded: int = 0
    reported: int = 0
    air_steps: int = 0

    def row(self) -> dict:
        """Return the counts as one table row.

        Returns
        -------
        dict of str to int
            Column name (those of :data:`WAVEFORM_UNITS`) → count.
        """
        return dict(beacons_due=self.due, lbt_dropped=self.dropped, collided=self.collided, decoded=self.decoded,
                    reported=self.reported, air_steps=self.air_steps)


#: (unit, description) of the columns of :meth:`WaveformStats.row`.
WAVEFORM_UNITS = {
    "beacons_due": ("1", "beacons due in the case (every tag, trial and epoch)"),
    "lbt_dropped": ("1", "beacons dropped after the last listen-before-talk attempt found the channel busy"),
    "collided": ("1", "beacons that overlapped another tag's beacon in time"),
    "decoded": ("1", "frames with a valid CRC, summed over the readers"),
    "reported": ("1", "decoded frames of the right epoch reported above the reader floor, summed over readers"),
    "air_steps": ("1", "air-interface steps run (reception clusters and carrier sensing)"),
}


def sample_level_reports(wf: WaveformConfig, plan, channel, data, *, waf_db: float, case: int, seed: int,
                         report: _rss_reader.RssReport):
    r"""Send the beacons of one case at sample level and return the readers' reports.

    Each tag → reader link is a log-distance model whose reference loss makes the channel's
    LoS power equal the drawn large-scale power
    :math:`P_{r,j} = \alpha_j - 10 n_j \log_{10} d_j - n_W \mathrm{WAF} + X_j + P_j`
    (:mod:`rfsim.channels.rss`; module docstring).

    Parameters
    ----------
    wf : WaveformConfig
        The sample-level settings.
    plan : rfsim.scenes.rss_rooms.FloorPlan
        Readers, walls, reference tags and heights.
    channel : rfsim.channels.rss.RssChannel
        The plan's channel (per-reader :math:`\alpha_j`, :math:`n_j`).
    data : rfsim.scenes.rss_rooms.CaseData
        The case's truth and drawn powers (B trials, T epochs, J readers, I reference tags).
    waf_db : float
        Wall attenuation per crossing [dB].
    case : int
        Index of the case (a key of the random streams).
    seed : int
        Root seed; trial b uses ``trial_rng(seed, case, 2, b)``.
    report : rfsim.devices.rss_reader.RssReport
        The readers' RSSI report (quantization, floor).

    Returns
    -------
    rss_dbm : ndarray, shape (B, T, J)
        Reported RSSI of the target [dBm]; NaN for a lost beacon.
    ref_rss_dbm : ndarray, shape (B, T, J, I)
        Reported RSSI of the reference tags [dBm]; NaN for a lost beacon.
    starts_s : ndarray, shape (B, T, 1 + I)
        The beacons' start times [s] (target first); NaN when listen-before-talk dropped one.
    stats : WaveformStats
        The case's counts.
    """
    b_n, t_n, j_n = data.rss_dbm.shape
    ref = plan.reference_xy
    i_n = ref.shape[0]
    walls = tuple(_large_scale.Wall.segment_2d((x0, y0), (x1, y1), waf_db) for x0, y0, x1, y1 in plan.walls_xy)
    apdp = _small_scale.ApdpModel() if wf.apdp else None
    rcfg = _active_reader.ActiveReaderConfig(fs_hz=wf.fs_hz, noise_figure_db=wf.noise_figure_db, report=report)
    readers = [_active_reader.ActiveReader(rcfg, _antennas.Antenna([x, y, plan.reader_height_m])) for x, y in plan.readers_xy]
    z = plan.tag_height_m
    ref_pts = np.column_stack([ref, np.full(i_n, z)]) if i_n else np.zeros((0, 3))
    out = np.full((b_n, t_n, j_n), np.nan)
    out_ref = np.full((b_n, t_n, j_n, i_n), np.nan)
    starts = np.full((b_n, t_n, 1 + i_n), np.nan)
    stats = WaveformStats()
    for b in range(b_n):
        rng = trial_rng(seed, case, 2, b)
        tcfg = dict(jitter_s=wf.jitter_s, lbt_listen_s=wf.lbt_listen_s, tx_power_dbm=TX_POWER_DBM)
        tags = [_active_tag.ActiveTag(_active_tag.ActiveTagConfig(tag_id=k + 1, **tcfg), None, rng=rng) for k in range(1 + i_n)]
        offsets = rng.uniform(wf.jitter_s, 1.0 - wf.jitter_s - tags[0].burst_s, size=len(tags))
        for t in range(t_n):
            target = np.array([*data.truth_xy[b, t], z])
            if i_n and np.min(np.linalg.norm(ref[:, :2] - target[:2], axis=1)) < SAME_SPOT_M:
                target[2] += SAME_SPOT_LIFT_M
            pts = np.vstack([target, ref_pts])                                            # (1 + I, 3)
            total = np.vstack([data.rss_dbm[b, t][None], data.ref_rss_dbm[b, t].T]) if i_n else data.rss_dbm[b, t][None]
            # Pr_j of the draws = the mean at the antenna's own (lifted or not) position + the rest
            mean = channel.mean_rss_dbm(pts)                                               # (1 + I, J)
            by_tag = {}
            for k, tag in enumerate(tags):
                tag.antenna = _antennas.Antenna(pts[k])
                tag.seq = t % 256           # beacon t carries sequence number t
                models = [(readers[j].antenna,
                           _large_scale.LogDistance(r.exponent, r.d0_m,
                                                    pl_d0_db=TX_POWER_DBM - r.alpha_dbm - (total[k, j] - mean[k, j])))
                          for j, r in enumerate(channel.readers)]
                scene = _scene.Scene(walls=walls, large_scale=_large_scale.LinkLargeScale(by_antenna=models), apdp=apdp, image_order=0)
                by_tag[id(tag.antenna)] = _TagTable(tag.antenna, _air.LinkTable(_scene.Channel(scene),
                                                                                rng=rng if apdp else None))
            common = _air.LinkTable(_scene.Channel(_scene.Scene(walls=walls, image_order=0)))
            run = _beacons.run_beacons(tags, readers, _TagLinks(by_tag, common), t0_s=float(t), t1_s=float(t + 1),
                                       fs_hz=wf.fs_hz, rng=rng, offsets_s=offsets + t)
            for burst in run.bursts:
                starts[b, t, burst.tag] = burst.t_s
            stats.due += len(run.bursts)
            stats.dropped += sum(r.lbt_dropped for r in run.bursts)
            stats.collided += sum(r.collided for r in run.bursts)
            stats.air_steps += run.steps + run.lbt_steps
            for j, reads in enumerate(run.reads):
                for rd in reads:
                    stats.decoded += rd.crc_ok
                    if not (rd.crc_ok and rd.seq == t % 256 and 1 <= rd.tag_id <= 1 + i_n):
                        continue
                    stats.reported += bool(np.isfinite(rd.rssi_reported_dbm))
                    if rd.tag_id == 1:
                        out[b, t, j] = rd.rssi_reported_dbm
                    else:
                        out_ref[b, t, j, rd.tag_id - 2] = rd.rssi_reported_dbm
    return out, out_ref, starts, stats


class _TagTable(NamedTuple):
    """One tag's links to the readers, kept with the tag antenna whose identity keys it."""

    antenna: object
    links: object


class _TagLinks:
    """The links of one epoch: a tag's links to the readers from that tag's own channel (its
    per-reader models carry its shadowing), tag ↔ tag links (listen-before-talk) from the
    common one. Tags are told apart by antenna identity: two tags may stand at one spot."""

    def __init__(self, by_tag: dict, common):
        self.by_tag, self.common = by_tag, common  # by_tag: id(tag antenna) → _TagTable

    def paths(self, tx, rx, *, fc_hz: float, t_s: float):
        a, b = self._table(tx), self._table(rx)
        table = self.common if (a is not None and b is not None) else (a or b or _TagTable(None, self.common)).links
        return table.paths(tx, rx, fc_hz=fc_hz, t_s=t_s)

    def _table(self, antenna) -> _TagTable | None:
        hit = self.by_tag.get(id(antenna))
        return hit if (hit is not None and hit.antenna is antenna) else None


__all__ = ["WaveformConfig", "WaveformStats", "WAVEFORM_UNITS", "sample_level_reports"]
