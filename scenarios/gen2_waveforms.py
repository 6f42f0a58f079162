"""Scenario ``gen2-waveforms``: one Gen2 inventory handshake per named link profile.

For each profile the reader sends Query, the tag answers RN16 after T1, the reader ACKs
after T2 and the tag answers PC+EPC+CRC-16 after T1 — the singulation of
gen2-and-validation-anchors.md §4.4 with the link timing of §4.3. The dataset holds

* ``profiles``: the link-profile table (Tari, data-1, RTcal, TRcal, PW, delimiter, DR, M,
  TRext, modulation, depth, BLF, FrT, bit rate);
* ``timing``: per profile T1 (min/nom/max), T2 (min/max), T4 and the durations of
  Query, QueryRep, ACK, the RN16 reply and the EPC reply;
* ``frames``: start/end time and bits (with CRC) of each frame of the exchange;
* ``exchange_<profile>``: the sampled exchange on a common time axis: the reader's PIE
  envelope (amplitude relative to the CW, 1 during CW) and the tag's backscatter state
  (±1 during replies, 0 while absorbing).

No channel, no noise: this is the protocol's own waveform, the reference every
sample-level device model is built from.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.gen2.link import PROFILES, profile, t1, t2, t4
from rfsim.core.rng import trial_rng
from rfsim.core.figure_style import OKABE_ITO, figure, legend_outside, paper_style
from rfsim.core.plots import figure_path, save_figure
from rfsim.core.references import cite
from rfsim.core.lazy import lazy_import

_dataset = lazy_import("rfsim.core.dataset")
_bits = lazy_import("rfsim.gen2.bits")
_commands = lazy_import("rfsim.gen2.commands")
_crc = lazy_import("rfsim.gen2.crc")
_linecode = lazy_import("rfsim.gen2.linecode")
_pie = lazy_import("rfsim.gen2.pie")
_tag_state = lazy_import("rfsim.devices.gen2_tag_state")

NAME = "gen2-waveforms"
DESCRIPTION = "Query/RN16/ACK/EPC exchange waveforms, link-profile and timing tables of the named Gen2 profiles"

#: Reader turnaround used in the exchange: T2 = 10 Tpri, inside the 3–20 Tpri window.
T2_TPRI = 10.0
#: CW before the Query [s] (the delimiter's falling edge must be visible to a decoder).
CW_LEAD_S = 100e-6


@dataclass(frozen=True)
class Config:
    """Configuration of the ``gen2-waveforms`` scenario.

    Every profile must allow ``fs_hz`` >= 8 × its BLF; ``epc_hex`` must be whole 16-bit words
    (at most 31).

    Attributes
    ----------
    profiles : tuple of str, default all of :data:`rfsim.gen2.link.PROFILES`
        Named link profiles to draw (at least one).
    fs_hz : float, default 8e6
        Sample rate of the waveforms [Hz], in [2e5, 2e8].
    q : int, default 4
        Q of the Query command, in [0, 15].
    session : int, default 0
        Inventory session S0-S3, in [0, 3].
    rn16 : int, default -1
        RN16 the tag replies; -1 draws it from the seed, in [-1, 65535].
    epc_hex : str, default "300833B2DDD9014000000027"
        EPC of the tag (hex, multiple of 16 bits).
    pie_rise_fall_tari : float, default 0.1
        PIE 10-90 % edge time (Gen2: <= 0.33 Tari) [Tari], in [0, 0.33].
    """

    profiles: tuple[str, ...] = param(tuple(PROFILES), doc="named link profiles to draw")
    fs_hz: float = param(8e6, lo=2e5, hi=2e8, unit="Hz", doc="sample rate of the waveforms")
    q: int = param(4, lo=0, hi=15, doc="Q of the Query command")
    session: int = param(0, lo=0, hi=3, doc="inventory session S0-S3")
    rn16: int = param(-1, lo=-1, hi=65535, doc="RN16 the tag replies; -1 draws it from the seed")
    epc_hex: str = param("300833B2DDD9014000000027", doc="EPC of the tag (hex, multiple of 16 bits)")
    pie_rise_fall_tari: float = param(0.1, lo=0.0, hi=0.33, unit="Tari",
                                      doc="PIE 10-90 % edge time (Gen2: <= 0.33 Tari)")

    def __post_init__(self):
        if not self.profiles:
            raise ConfigError("profiles", list(self.profiles), "at least one of " + ", ".join(PROFILES))
        for i, name in enumerate(self.profiles):
            try:
                link = profile(name)
            except ConfigError as err:
                raise ConfigError(f"profiles[{i}]", name, err.allowed) from None
            if self.fs_hz < 8 * link.blf_hz:
                raise ConfigError("fs_hz", self.fs_hz,
                                  f">= 8 x BLF of profile {name!r} = {8 * link.blf_hz:g} Hz")
        text = self.epc_hex.replace(" ", "")
        if not text or len(text) % 4 or len(text) > 124 or any(c not in "0123456789abcdefABCDEF" for c in text):
            raise ConfigError("epc_hex", self.epc_hex, "hex digits, a multiple of 4 (16-bit words), at most 31 words")


def run(config: Config, *, seed: int) -> _dataset.Dataset:
    """Simulate one Gen2 inventory handshake (Query, RN16, ACK, PC+EPC+CRC-16) per link profile.

    The singulation of gen2-and-validation-anchors.md §4.4 with the link timing of §4.3
    (:mod:`rfsim.gen2.link`), sampled at ``fs_hz``, the reader turnaround T2 = 10 Tpri; no
    channel and no noise.

    Parameters
    ----------
    config : Config
        Scenario configuration.
    seed : int
        Root seed; the RN16 (when ``config.rn16`` is -1) is drawn from ``trial_rng(seed, 0)``.

    Returns
    -------
    rfsim.core.dataset.Dataset
        Tables ``profiles`` (one row per link profile: Tari, data-1, RTcal, TRcal, PW,
        delimiter [s], DR, M, TRext, modulation, depth, BLF [Hz], FrT, bit rate [bit/s]),
        ``timing`` (T1 min/nom/max, T2 min/max, T4 min and the command and reply durations
        [s]), ``frames`` (start, end [s] and bits of each frame) and ``exchange_<profile>``
        (time [s], reader PIE envelope relative to the CW, tag backscatter state ±1/0); root
        attributes ``rn16`` and ``t2_reader_tpri``.
    """
    rng = trial_rng(seed, 0)
    rn16 = int(rng.integers(0, 2**16)) if config.rn16 < 0 else config.rn16
    epc = _bits.hex_to_bits(config.epc_hex.replace(" ", ""))
    epc_reply = _crc.append_crc16(np.concatenate([_bits.int_to_bits(_tag_state.pc_word(epc), 16), epc]))
    rn16_bits = _bits.int_to_bits(rn16, 16)

    ds = _dataset.Dataset(title="EPC Gen2 link profiles, timing and exchange waveforms")
    rows: dict[str, list] = {k: [] for k in ("profile", "frame", "start_s", "end_s", "bits")}
    prof_rows: dict[str, list] = {}
    timing_rows: dict[str, list] = {}
    for name in config.profiles:
        link = profile(name)
        query = _commands.Query(dr=link.dr, m=link.m, trext=link.trext, session=config.session, q=config.q)
        ack = _commands.ACK(rn16)
        _append(prof_rows, profile=name, tari_s=link.tari_s, data1_s=link.data1_s,
                rtcal_s=link.rtcal_s, trcal_s=link.trcal_s, pw_s=link.pw_s,
                delimiter_s=link.delimiter_s, dr=link.dr, m=link.m, trext=link.trext,
                modulation=link.modulation, depth=link.depth, blf_hz=link.blf_hz,
                frt=link.frt, bitrate_bps=link.bitrate_bps)
        _append(timing_rows, profile=name, t1_min_s=t1(link).min_s, t1_nom_s=t1(link).nom_s,
                t1_max_s=t1(link).max_s, t2_min_s=t2(link).min_s, t2_max_s=t2(link).max_s,
                t4_min_s=t4(link).min_s, query_s=link.command_duration_s(query),
                queryrep_s=link.command_duration_s(_commands.QueryRep(config.session)),
                ack_s=link.command_duration_s(ack), rn16_reply_s=link.reply_duration_s(16),
                epc_reply_s=link.reply_duration_s(epc_reply.size))
        time_s, reader, tag, frames = _exchange(link, query, ack, rn16_bits, epc_reply,
                                                config.fs_hz, config.pie_rise_fall_tari)
        for frame, (start, end, bits) in frames.items():
            _append(rows, profile=name, frame=frame, start_s=start, end_s=end, bits=_bits.bits_to_str(bits))
        ds.add_table(f"exchange_{name}", {
            "time_s": _dataset.column(time_s, "s", "time since the start of the CW (the Query starts at 100 us)"),
            "reader_envelope": _dataset.column(reader, "1", "reader PIE amplitude envelope relative to the CW"),
            "tag_state": _dataset.column(tag, "1", "tag backscatter state: +1/-1 during replies, 0 absorbing"),
        }, description=f"the sampled exchange of profile {name}: reader PIE envelope and tag backscatter state "
                       f"on one time axis at fs_hz")
    ds.add_table("profiles", _columns(prof_rows, PROFILE_COLUMNS),
                 description="one row per named link profile: the reader's PIE parameters and the tag link")
    ds.add_table("timing", _columns(timing_rows, TIMING_COLUMNS),
                 description="one row per profile: Gen2 link timing T1, T2, T4 and command/reply durations")
    ds.add_table("frames", _columns(rows, FRAME_COLUMNS),
                 description="one row per frame of each profile's exchange: start, end and bits")
    ds.attrs["rn16"] = rn16
    ds.attrs["t2_reader_tpri"] = T2_TPRI
    return ds


def _exchange(link, query, ack, rn16_bits, epc_reply, fs_hz, rise_fall_tari):
    """Sample CW → Query → T1 → RN16 → T2 → ACK → T1 → EPC on one time axis at ``fs_hz``."""
    rf = rise_fall_tari * link.tari_s
    t_query = CW_LEAD_S + link.command_duration_s(query)
    t_rn16 = t_query + t1(link).nom_s
    t_ack = t_rn16 + link.reply_duration_s(16) + T2_TPRI * link.tpri_s
    t_epc = t_ack + link.command_duration_s(ack) + t1(link).nom_s
    t_end = t_epc + link.reply_duration_s(epc_reply.size)
    n = int(np.ceil(t_end * fs_hz)) + 1
    time_s = np.arange(n) / fs_hz
    reader = np.ones(n)
    q_env = _pie.pie_envelope_for_profile(_commands.encode(query), link, fs_hz=fs_hz, preamble="query", rise_fall_s=rf,
                                          cw_before_s=CW_LEAD_S)
    reader[:q_env.size] = q_env
    a_env = _pie.pie_envelope_for_profile(_commands.encode(ack), link, fs_hz=fs_hz, preamble="frame-sync", rise_fall_s=rf)
    i_ack = int(np.ceil(t_ack * fs_hz))
    reader[i_ack:i_ack + a_env.size] = a_env[: n - i_ack]
    tag = (_linecode.reply_waveform_for_profile(rn16_bits, link, fs_hz=fs_hz, t0_s=t_rn16, n_samples=n)
           + _linecode.reply_waveform_for_profile(epc_reply, link, fs_hz=fs_hz, t0_s=t_epc, n_samples=n))
    frames = {
        "Query": (CW_LEAD_S, t_query, _commands.encode(query)),
        "RN16": (t_rn16, t_rn16 + link.reply_duration_s(16), rn16_bits),
        "ACK": (i_ack / fs_hz, i_ack / fs_hz + link.command_duration_s(ack), _commands.encode(ack)),
        "EPC": (t_epc, t_end, epc_reply),
    }
    return time_s, reader, tag, frames


PROFILE_COLUMNS = {
    "profile": ("", "link profile name"), "tari_s": ("s", "Tari (data-0 length)"),
    "data1_s": ("s", "length of a PIE data-1 symbol (1.5-2 Tari)"), "rtcal_s": ("s", "RTcal = data-0 + data-1"),
    "trcal_s": ("s", "TRcal, the tag-to-reader calibration symbol of the Query preamble (BLF = DR/TRcal)"),
    "pw_s": ("s", "PIE low-pulse width"),
    "delimiter_s": ("s", "length of the delimiter that starts every reader command (12.5 us nominal)"),
    "dr": ("", "divide ratio (8 or 64/3)"),
    "m": ("1", "subcarrier cycles per bit (1 = FM0)"), "trext": ("1", "pilot tone requested"),
    "modulation": ("", "reader modulation: DSB-ASK, SSB-ASK or PR-ASK"), "depth": ("1", "modulation depth (A-B)/A"),
    "blf_hz": ("Hz", "backscatter link frequency DR/TRcal"),
    "frt": ("1", "BLF tolerance FrT (nominal temperature)"),
    "bitrate_bps": ("bit/s", "tag data rate BLF/M"),
}
TIMING_COLUMNS = {
    "profile": ("", "link profile name"),
    "t1_min_s": ("s", "T1 minimum: earliest tag reply after the reader command's last rising edge"),
    "t1_nom_s": ("s", "T1 nominal, max(RTcal, 10 Tpri) (the tag replies this long after the command)"),
    "t1_max_s": ("s", "T1 maximum: latest tag reply after the reader command's last rising edge"),
    "t2_min_s": ("s", "T2 minimum (3 Tpri)"), "t2_max_s": ("s", "T2 maximum (20 Tpri)"),
    "t4_min_s": ("s", "T4 minimum (2 RTcal)"), "query_s": ("s", "Query duration incl. preamble"),
    "queryrep_s": ("s", "QueryRep duration incl. frame-sync"),
    "ack_s": ("s", "ACK duration incl. frame-sync"),
    "rn16_reply_s": ("s", "RN16 reply duration (preamble + 16 bits + dummy 1)"),
    "epc_reply_s": ("s", "PC+EPC+CRC-16 reply duration"),
}
FRAME_COLUMNS = {
    "profile": ("", "link profile name"), "frame": ("", "Query, RN16, ACK or EPC"),
    "start_s": ("s", "start time of the frame on the exchange's time axis"),
    "end_s": ("s", "end time of the frame on the exchange's time axis"),
    "bits": ("", "frame bits, MSB first, incl. CRC where Gen2 has one"),
}


def _append(rows: dict[str, list], **values) -> None:
    for k, v in values.items():
        rows.setdefault(k, []).append(v)


def _columns(rows: dict[str, list], spec: dict[str, tuple[str, str]]):
    return {k: _dataset.column(rows[k], *spec[k]) for k in spec}


#: Approximate width [px] of a left panel of the figure (5 in at 200 dpi).
_PANEL_PX = 1000
#: Vertical placement of the two traces: the reader envelope in [0, 1], the tag state ±1
#: drawn at TAG_OFFSET ± 0.5.
TAG_OFFSET = -1.0


def plot(dataset_path: Path, out_dir: Path) -> list[Path]:
    """Per profile: the whole exchange (left) and the start of the RN16 reply (right),
    ``<stem>-exchange.png``.

    The reader's PIE envelope (relative to the CW, 0…1) and the tag's backscatter state (±1,
    drawn below it) share a time axis; each frame (Query, RN16, ACK, PC+EPC+CRC-16) is named
    at its place, reader frames above the envelope, tag frames below the tag trace. On the
    whole exchange a fast tag link (e.g. Miller-4 at 320 kHz: 1.28 M state changes per second)
    is finer than a pixel, so it is drawn as a band and the right panels zoom on the first 6
    bits of the RN16 reply (preamble), the interval shaded grey on the left.

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
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    from matplotlib.ticker import MaxNLocator

    from rfsim.core.dataset import read_dataset

    ds = read_dataset(dataset_path)
    names = list(ds.tables["profiles"]["profile"].data)
    prof = {k: c.data for k, c in ds.tables["profiles"].items()}
    frames = {k: c.data for k, c in ds.tables["frames"].items()}
    reader_style, tag_style = dict(color=OKABE_ITO[0], lw=0.8), dict(color=OKABE_ITO[1], lw=0.7, ls="-")
    with paper_style():
        fig, axes = figure(columns=2, nrows=len(names), ncols=2, height_in=1.65 * len(names) + 0.7,
                           squeeze=False, gridspec_kw={"width_ratios": [3, 1]})
        for (ax, zoom), name in zip(axes, names):
            ex = ds.tables[f"exchange_{name}"]
            t_ms = ex["time_s"].data * 1e3
            reader, tag = ex["reader_envelope"].data, 0.5 * ex["tag_state"].data + TAG_OFFSET
            zoom.sharey(ax)  # same scale; the y label is the left panel's
            for a in (ax, zoom):
                a.plot(t_ms, reader, **reader_style)
                a.set_yticks([TAG_OFFSET - 0.5, TAG_OFFSET + 0.5, 0.0, 1.0], ["−1", "+1", "0", "1"])
                a.set_ylim(TAG_OFFSET - 1.0, 1.55)
                a.set_xlabel(r"time $t$ [ms]")
                a.grid(axis="y", visible=False)
            ax.set_ylabel("tag state | reader\nenvelope [rel. CW]", fontsize=6.5)
            zoom.plot(t_ms, tag, **tag_style)
            changes = int(np.count_nonzero(np.diff(ex["tag_state"].data)))
            if changes > 0.3 * _PANEL_PX:  # finer than a pixel: draw where the tag replies, say so
                replying = ex["tag_state"].data != 0
                ax.fill_between(t_ms, TAG_OFFSET - 0.5, TAG_OFFSET + 0.5, where=replying,
                                color=OKABE_ITO[1], alpha=0.35, lw=0)
            else:
                ax.plot(t_ms, tag, **tag_style)
            for k in np.flatnonzero(frames["profile"] == name):
                frame = str(frames["frame"][k])
                mid = 0.5e3 * (float(frames["start_s"][k]) + float(frames["end_s"][k]))
                from_tag = frame in ("RN16", "EPC")
                ax.text(mid, TAG_OFFSET - 0.62 if from_tag else 1.08, "PC+EPC+CRC" if frame == "EPC" else frame,
                        ha="center", va="top" if from_tag else "bottom", fontsize=6.5,
                        color=OKABE_ITO[1] if from_tag else OKABE_ITO[0])
            i = int(np.flatnonzero(prof["profile"] == name)[0])
            m, bitrate = int(prof["m"][i]), float(prof["bitrate_bps"][i])
            ax.set_title(f"{name}: BLF {prof['blf_hz'][i] / 1e3:g} kHz, "
                         f"{'FM0' if m == 1 else f'Miller-{m}'}, Tari {prof['tari_s'][i] * 1e6:g} $\\mu$s",
                         loc="left")
            rn16 = np.flatnonzero((frames["profile"] == name) & (frames["frame"] == "RN16"))
            if rn16.size:
                t0 = float(frames["start_s"][rn16[0]])
                zoom.set_xlim(t0 * 1e3, (t0 + 6.0 / bitrate) * 1e3)
                ax.axvspan(t0 * 1e3, (t0 + 6.0 / bitrate) * 1e3, color="0.85", zorder=0)
            zoom.set_title("start of the RN16 (6 bits)")
            zoom.xaxis.set_major_locator(MaxNLocator(3))
        handles = [Line2D([], [], **reader_style, label="reader PIE envelope (rel. CW)"),
                   Line2D([], [], **tag_style, label="tag backscatter state ±1"),
                   Patch(color=OKABE_ITO[1], alpha=0.35, lw=0, label="tag replying (finer than a pixel)"),
                   Patch(color="0.85", label="interval zoomed on the right")]
        legend_outside(axes[-1, 0], where="below", handles=handles, ncols=2)
        fig.suptitle(f"Query → RN16 → ACK → PC+EPC+CRC-16 per link profile ({cite('gen2')}; "
                     "no channel, no noise)")
        return [save_figure(fig, figure_path(dataset_path, out_dir, "exchange"), dpi=200)]
