"""A reader, a tag and sense-a-tag (ST) antennas around it: one Query exchange through the air
step, heard by many ST positions at once (the scene of the phase-cancellation scenario).

Scene: the reader antenna at (0, 0, h) (patch, boresight +x), the tag at (x, 0, h) (a vertical
half-wave dipole facing the reader, or PASS's 'l2-dipole' file with
:class:`rfsim.devices.pass_tag.PassReplicationConfig`), ST antennas anywhere (vertical half-wave
dipoles, or PASS's file too). Channel: Friis + the exponential APDP with the PASS ST-room curves
when ``apdp`` (:class:`rfsim.channels.small_scale.ApdpModel`; surfaces off).

Steps (:func:`simulate_exchange`): the reader sends a Query followed by CW; the tag receives it
through its drawn forward link, decodes it and answers its RN16 with Γ(t)
(:class:`rfsim.devices.tag.PassiveTag`), re-radiating r(t) = A_s − Γ(t), in one step of the air
interface (:func:`rfsim.air.step.propagate`) over the whole segment. Every ST antenna hears it at
once (a batch of N positions × k antennas) in a second step over the ST window (from the end of
the command on) with the tag's decided r(t) replayed: with narrowband links (the one rule of
:func:`rfsim.channels.paths.propagation_method`, :class:`rfsim.channels.bulk.BatchLink`; a
wideband link is an error, and the window step gives the same samples as the whole segment's)
the input at antenna k is ``a_k·x_tx(t) + b_k·r(t)·x_inc(t)`` with ``a_k``, ``b_k`` the drawn
reader→SA_k and tag→SA_k gains (:func:`rfsim.channels.bulk.draw_links`). With two antennas the
stamped frame is a third step on the same links with the three-state modulator's r(t)
(S1 = r_B, S2 = r_A, S3 = r_B·e^{jψ}, :mod:`rfsim.devices.st_pair`), and the pair's mutual
coupling (:func:`rfsim.devices.st_pair.couple_ports`) mixes the ports when ``pair_coupling``.
Thermal noise k·T0·fs·F per sample at every ST antenna when ``noise_figure_db`` is given.

Randomness: for ``index`` (a tuple) ``trial_rng(seed, *index, k)``: k = 0 reader, 1 tag,
2 forward link, 5 ST noise; the ST links are drawn from ``link_rng`` (reader→SA, then tag→SA).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from rfsim.air import noise as _noise
from rfsim.air import step as _air
from rfsim.channels import antennas as _antennas
from rfsim.channels import bulk as _bulk
from rfsim.channels import paths as _paths
from rfsim.channels import scene as _channels_scene
from rfsim.channels.small_scale import ApdpModel
from rfsim.core.rng import trial_rng
from rfsim.core.units import wavelength_m
from rfsim.devices import st_analytic as sa
from rfsim.devices import st_pair
from rfsim.devices import st_receiver as sr
from rfsim.devices.pass_tag import PASS_TAG_ANTENNA_FILE, PassReplicationConfig, TagStatesConfig, make_tag
from rfsim.devices.reader import Reader
from rfsim.devices.reader_config import ReaderConfig
from rfsim.devices.sense_a_tag import listen_start_sample, st_antenna_positions
from rfsim.devices.tag_config import TagConfig
from rfsim.gen2 import commands as _commands
from rfsim.gen2 import link as _link
from rfsim.gen2.linecode import reply_waveform

#: RF peak volts per √W at the ST's 50 Ω reference impedance, sqrt(2R)
V_PER_SQRT_W = math.sqrt(2.0 * sr.REFERENCE_IMPEDANCE_OHM)


@dataclass(frozen=True)
class TagListeningScene:
    """What the scene is made of.

    Attributes
    ----------
    reader : rfsim.devices.reader_config.ReaderConfig
        The reader.
    tag : rfsim.devices.tag_config.TagConfig
        The tag.
    tag_states : rfsim.devices.pass_tag.TagStatesConfig
        The tag's reflection states.
    pass_replication : rfsim.devices.pass_tag.PassReplicationConfig
        PASS replication (antenna files).
    height_m : float
        Common height of reader, tag and ST antennas [m].
    reader_gain_dbi : float
        Reader patch gain [dBi].
    apdp : bool
        Add the exponential APDP (PASS ST-room curves).
    pair_coupling : bool
        Mix the two ST ports by their mutual coupling.
    st_spacing_m : float
        Spacing of the ST's antenna pair [m].
    noise_figure_db : float or None
        ST noise figure [dB]; None: no noise.
    """

    reader: ReaderConfig
    tag: TagConfig
    tag_states: TagStatesConfig
    pass_replication: PassReplicationConfig
    height_m: float
    reader_gain_dbi: float
    apdp: bool
    pair_coupling: bool
    st_spacing_m: float
    noise_figure_db: float | None


@dataclass(frozen=True)
class _PatternFile:
    """A loaded pattern file: the file's identity when it was read (resolved path, size [B],
    modification time [ns]) and the pattern read from it."""

    path: str
    size_b: int
    mtime_ns: int
    pattern: _antennas.Tabulated


#: The pattern files read so far, by resolved path; an entry is used only while the file's size and
#: modification time are those it was read with (a changed file is read again). At most
#: :data:`_PATTERN_FILES_MAX` entries.
_PATTERN_FILES: dict[str, _PatternFile] = {}
_PATTERN_FILES_MAX = 4


def pass_tag_pattern(characteristics_dir: str) -> _antennas.Tabulated:
    """Return PASS's tag antenna pattern as it is (peak amplitude 2.0, power 4.0).

    The file is read once and kept while it is unchanged (same resolved path, size and
    modification time; a changed file is read again).

    Parameters
    ----------
    characteristics_dir : str
        Folder holding PASS's characteristic files (:data:`rfsim.devices.pass_tag.PASS_TAG_ANTENNA_FILE`).

    Returns
    -------
    rfsim.channels.antennas.Tabulated
        The pattern.

    Raises
    ------
    OSError
        The file cannot be read (as :meth:`rfsim.channels.antennas.Tabulated.from_pass_mat`).
    """
    path = (Path(characteristics_dir) / PASS_TAG_ANTENNA_FILE).resolve()
    stat = path.stat()
    hit = _PATTERN_FILES.get(str(path))
    if hit is not None and hit.size_b == stat.st_size and hit.mtime_ns == stat.st_mtime_ns:
        return hit.pattern
    pattern = _antennas.Tabulated.from_pass_mat(path)
    if len(_PATTERN_FILES) >= _PATTERN_FILES_MAX:
        _PATTERN_FILES.clear()
    _PATTERN_FILES[str(path)] = _PatternFile(str(path), stat.st_size, stat.st_mtime_ns, pattern)
    return pattern


def room(apdp: bool) -> _channels_scene.Scene:
    """Return the scene's channel: Friis, optionally with the exponential APDP.

    Parameters
    ----------
    apdp : bool
        Add the exponential APDP with the PASS ST-room curves (:class:`rfsim.channels.small_scale.ApdpModel`).

    Returns
    -------
    rfsim.channels.scene.Scene
        The scene (no surfaces).
    """
    return _channels_scene.Scene(apdp=ApdpModel() if apdp else None)


def reader_antenna(s: TagListeningScene) -> _antennas.Antenna:
    """Return the reader's patch at (0, 0, h), boresight +x, 70° beamwidth, linearly polarized.

    Parameters
    ----------
    s : TagListeningScene
        The scene. (h = ``s.height_m``, gain ``s.reader_gain_dbi``).

    Returns
    -------
    rfsim.channels.antennas.Antenna
        The reader antenna.
    """
    return _antennas.Antenna(position_m=(0.0, 0.0, s.height_m), orientation=(0.0, 0.0, 0.0),
                             pattern=_antennas.Patch(s.reader_gain_dbi, 70.0), polarization="linear")


def tag_antenna(x_m: float, s: TagListeningScene) -> _antennas.Antenna:
    """Return the tag's antenna at (x, 0, h), facing the reader, axis vertical.

    A half-wave dipole (as in the link scenario), or PASS's file when replicating (both
    patterns along the local z axis).

    Parameters
    ----------
    x_m : float
        x of the tag [m].
    s : TagListeningScene
        The scene.

    Returns
    -------
    rfsim.channels.antennas.Antenna
        The tag antenna.
    """
    pr = s.pass_replication
    pattern = pass_tag_pattern(pr.characteristics_dir) if pr.enabled else _antennas.HalfWaveDipole()
    return _antennas.Antenna(position_m=(x_m, 0.0, s.height_m), orientation=(math.pi, 0.0, 0.0),
                             pattern=pattern, polarization="linear")


def st_links(s: TagListeningScene, fc_hz: float, sa_pos, tag_ant, rng):
    """Draw the batched links reader→SA and tag→SA, in that order.

    Parameters
    ----------
    s : TagListeningScene
        The scene.
    fc_hz : float
        Carrier frequency [Hz].
    sa_pos : ndarray, shape (N, k, 3)
        ST antenna positions [m].
    tag_ant : rfsim.channels.antennas.Antenna
        The tag's antenna.
    rng : numpy.random.Generator
        Draws both batches.

    Returns
    -------
    reader_links : rfsim.channels.bulk.BatchLink
        Reader → every ST antenna, shape (N, k) (:meth:`rfsim.channels.bulk.BulkPaths.batch_link`).
    tag_links : rfsim.channels.bulk.BatchLink
        Tag → every ST antenna, shape (N, k).
    """
    ra = reader_antenna(s)
    pr = s.pass_replication
    sta = _antennas.vertical_dipole(np.zeros(3))
    if pr.enabled and pr.st_antenna_file:  # PASS's sensatag antenna: the tag's file, vertical (local z)
        sta = replace(sta, pattern=pass_tag_pattern(pr.characteristics_dir))
    n, k, _ = sa_pos.shape
    flat = sa_pos.reshape(-1, 3)
    scene = room(s.apdp)
    return tuple(_bulk.draw_links(scene, src.position_m, flat, fc_hz=fc_hz, rng=rng, tx_antenna=src,
                                  rx_antenna=sta).batch_link((n, k)) for src in (ra, tag_ant))


@dataclass(frozen=True, eq=False)
class Exchange:
    """One exchange through the air step, from the command end on (the ST window).

    Attributes
    ----------
    x_tx : ndarray of complex128, shape (n,)
        The reader's segment [√W].
    inc : ndarray of complex128, shape (n,)
        The field incident on the tag [√W].
    inputs : ndarray of complex128, shape (N, k, n), or None
        Input of every ST antenna (k = 2: SA1, SA2; k = 1: SA2) during the RN16 reply [√W];
        None when the tag did not reply.
    stamp_inputs : ndarray of complex128, shape (N, k, n), or None
        The same with the tag sending the stamped frame; None unless k = 2 and the tag replied.
    a_gain : ndarray of complex, shape (N, k)
        Narrowband gains reader→SA.
    b_gain : ndarray of complex, shape (N, k)
        Narrowband gains tag→SA.
    narrowband_error : float
        Largest relative envelope error of the ST links
        (:meth:`rfsim.channels.bulk.BulkPaths.narrowband_rms_error` on 2·BLF).
    levels : ndarray, shape (n,)
        True line-code levels.
    frame : rfsim.devices.st_receiver.StampFrame or None
        The stamped frame (indices relative to the window).
    i_ref : int
        A CW sample inside the reply.
    search : int
        Decoder search window [samples].
    rerad_a : complex
        Re-radiated absorbing state A_s − Γ_A.
    rerad_b : complex
        Re-radiated modulating state A_s − Γ_B.
    rn16 : ndarray of uint8, shape (16,), or None
        The RN16 the tag sent.
    fs_hz : float
        Sample rate [Hz].
    fc_hz : float
        Carrier [Hz].
    blf_hz : float
        The tag's BLF [Hz] (the nominal one without a reply).
    m : int
        Miller M of the reply (1: FM0).
    trext : bool
        Pilot tone of the reply.
    p_available_w : float
        CW power available at the tag antenna [W] (NaN unless 'measured').
    p_chip_w : float
        CW power absorbed by the chip [W] (NaN unless 'measured').
    """

    x_tx: np.ndarray
    inc: np.ndarray
    inputs: np.ndarray
    stamp_inputs: np.ndarray | None
    a_gain: np.ndarray
    b_gain: np.ndarray
    narrowband_error: float
    levels: np.ndarray
    frame: sr.StampFrame | None
    i_ref: int
    search: int
    rerad_a: complex
    rerad_b: complex
    rn16: np.ndarray | None
    fs_hz: float
    fc_hz: float
    blf_hz: float
    m: int
    trext: bool
    p_available_w: float
    p_chip_w: float

    def phasors_v(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return the antenna-level phasors at the reference sample ``i_ref``.

        RF peak volts at 50 Ω (:data:`V_PER_SQRT_W`), AURIS Eq. 3.4.

        Returns
        -------
        cw_v : ndarray of complex, shape (N, k)
            The CW from the reader [V].
        bs_modulating_v : ndarray of complex, shape (N, k)
            The backscatter in the modulating state, A_T1 [V].
        bs_absorbing_v : ndarray of complex, shape (N, k)
            The backscatter in the absorbing state, A_T2 [V].
        """
        cw = V_PER_SQRT_W * self.a_gain * self.x_tx[self.i_ref]
        bs1 = V_PER_SQRT_W * self.b_gain * self.rerad_b * self.inc[self.i_ref]
        bs2 = V_PER_SQRT_W * self.b_gain * self.rerad_a * self.inc[self.i_ref]
        return cw, bs1, bs2


@dataclass(frozen=True, eq=False)
class _STAntennas:
    """The ST antennas of all N positions, (N, k, 3) [m]: one batched receiver of the air step."""

    positions_m: np.ndarray


@dataclass(frozen=True, eq=False)
class _Replay:
    """A reflector whose re-radiation factor r(t) is already decided (reflector and reflection
    of the air step): the tag's reply replayed on the ST window, or the stamp transmitter —
    the same tag re-radiating its stamped frame through the three-state modulator (S1 = r_B,
    S2 = r_A, S3 = r_B·e^{jψ}; S1 outside the frame)."""

    antenna: object
    r: np.ndarray
    scatters = True
    constant_reradiation = None

    def reflect(self, incident):
        return self

    def reradiation(self, n_samples: int) -> np.ndarray:
        return self.r


def simulate_exchange(s: TagListeningScene, tag_x_m: float, sa_pos, *, seed: int, index: tuple[int, ...],
                      link_rng: np.random.Generator) -> Exchange:
    """Run the air steps of one exchange (module docstring).

    Reader Query segment → tag (forward link, PIE decode, RN16 as Γ(t), re-radiated as
    (A_s − Γ(t))·incident); if it replied, the ST antennas hear it on the ST window, and with
    two antennas the stamped frame too.

    Parameters
    ----------
    s : TagListeningScene
        The scene.
    tag_x_m : float
        x of the tag [m].
    sa_pos : array_like, shape (N, k, 3)
        ST antenna positions [m].
    seed : int
        Root seed.
    index : tuple of int
        Stream key: ``trial_rng(seed, *index, k)``, k = 0 reader, 1 tag, 2 forward link, 5 ST noise.
    link_rng : numpy.random.Generator
        Draws the ST links (reader→SA, then tag→SA).

    Returns
    -------
    Exchange
        The exchange from the command end on.

    Raises
    ------
    ValueError
        The reader–tag link or an ST link is not narrowband.
    """
    ra = reader_antenna(s)
    reader = Reader(s.reader, [ra], rng=trial_rng(seed, *index, 0))
    ta = tag_antenna(tag_x_m, s)
    lk = reader.link
    stamp_s = (2.0 * st_pair.STAMP_CYCLES + st_pair.STAMP_SETTLE_CYCLES + 2.0) / lk.blf_hz
    # the RN16 reply window with room for the stamp before the reply and one Tpri more
    window = _link.reply_window_s(lk, 16) + stamp_s + lk.tpri_s
    q = _commands.Query(dr=lk.dr, m=lk.m, trext=lk.trext, q=0)
    tx = reader.transmit(q, t0_s=0.0, cw_after_s=window)
    fs, fc = tx.fs_hz, tx.fc_hz
    tag = make_tag(s.tag, s.tag_states, s.pass_replication, ta, fc, trial_rng(seed, *index, 1))
    fwd = _bulk.draw_links(room(s.apdp), ra.position_m, ta.position_m, fc_hz=fc, rng=trial_rng(seed, *index, 2),
                           tx_antenna=ra, rx_antenna=ta).pathset(0)
    sta = _STAntennas(np.asarray(sa_pos))
    a_link, b_link = st_links(s, fc, sta.positions_m, ta, link_rng)
    links = _channels_scene.HeldLinks([(ra, ta, fwd), (ra, sta, a_link), (ta, sta, b_link)])
    bw = 2.0 * lk.blf_hz
    # 1. the tag decides on the whole segment
    air = _air.propagate([_air.FixedEmitter(ra, tx, device=reader)], [tag], [], links, t0_s=tx.t0_s, fs_hz=fs,
                         n_samples=tx.samples.size, bandwidth_hz=bw)
    inc, resp = air.incident[0].samples, air.reflections[0]
    op = tag.operating_point
    p_av, p_chip = (op.p_available_w, op.p_chip_w) if op is not None else (float("nan"), float("nan"))
    i0 = listen_start_sample(tx.cmd_end_s, t0_s=tx.t0_s, fs_hz=fs)
    x_tx, inc_w = tx.samples[i0:], inc[i0:]
    n = x_tx.size
    a_s = resp.structural_mode
    r_a, r_b = a_s - complex(tag.reflection_states.gamma_a), a_s - complex(tag.reflection_states.gamma_b)
    search = int(math.ceil((_link.t1(lk).max_s + 2 * lk.tpri_s) * fs))
    blf = resp.blf_hz if resp.gamma is not None else lk.blf_hz
    err = max(a_link.narrowband_error(2.0 * blf), b_link.narrowband_error(2.0 * blf))
    shape = sta.positions_m.shape[:2]
    coupled = s.pair_coupling and shape[1] == 2
    mix = sa.coupling_matrix(z12_ohm=complex(sa.mutual_impedance_half_wave_ohm(s.st_spacing_m, fc))) \
        if coupled else None

    def couple(x):
        return st_pair.couple_ports(mix, x) if coupled else x

    common = dict(a_gain=couple(a_link.constant_gain(fc).reshape(shape)),
                  b_gain=couple(b_link.constant_gain(fc).reshape(shape)),
                  narrowband_error=err, fs_hz=fs, fc_hz=fc, blf_hz=blf, m=lk.m, trext=lk.trext, p_available_w=p_av,
                  p_chip_w=p_chip)
    if resp.gamma is None:
        # no reply: the tag keeps reflecting its unmodulated state (PASS: unmodulated
        # reflection), both "states" are r_A and nothing is detectable (no ST step needed)
        return Exchange(x_tx, inc_w, None, None, levels=np.zeros(n), frame=None, i_ref=n // 2, search=search,
                        rerad_a=r_a, rerad_b=r_a, rn16=None, **common)
    if fwd.method(bw) != "narrowband" or not fwd.static:
        raise ValueError(f"the reader-tag link is not narrowband (error {_paths.narrowband_rms_error(fwd, bw):.3g} > "
                         f"{_paths.NARROWBAND_TOLERANCE}): these scenes need narrowband links")
    # 2. the ST antennas hear the reply: one step on the ST window [i0, end) with the tag's
    #    decided re-radiation replayed (narrowband links: the same samples as the whole segment's)
    win = _air.Segment(tx.t0_s + i0 / fs, fs, fc, x_tx)
    noise_w = 0.0 if s.noise_figure_db is None else float(_noise.thermal_noise_power_w(fs, s.noise_figure_db))
    port = _air.AntennaPort(sta, noise_power_w=noise_w)  # k·T0·fs·F per sample at every ST antenna
    noise_rng = trial_rng(seed, *index, 5)

    def hear(r_window):
        return _air.propagate([_air.FixedEmitter(ra, win, device=reader)], [_Replay(ta, r_window)], [port], links,
                              t0_s=win.t0_s, fs_hz=fs, n_samples=n, bandwidth_hz=bw, rng=noise_rng).inputs[0].samples

    inputs = couple(hear(resp.reradiation(inc.size)[i0:]))
    t_rel = (resp.reply_start_s - tx.t0_s) - i0 / fs  # reply start within the window [s]
    levels = reply_waveform(resp.reply.bits, m=resp.m, trext=resp.trext, blf_hz=resp.blf_hz, fs_hz=fs,
                            t0_s=t_rel, n_samples=n)
    frame = _window_frame(resp, fs, t_rel, n)
    stamp_inputs = None
    if shape[1] == 2:
        # 3. the stamped frame on the same links: the three-state modulator's re-radiated states
        #    S1 = r_B, S2 = r_A, S3 = r_B·e^{jψ}
        stamp_inputs = couple(hear(np.array([r_b, r_a, r_b * np.exp(1j * st_pair.STAMP_PSI_RAD)])[frame.states]))
    i_ref = int(round((t_rel + 0.5 * lk.reply_duration_s(16)) * fs))
    common.update(m=resp.m, trext=resp.trext)
    return Exchange(x_tx, inc_w, inputs, stamp_inputs, levels=levels, frame=frame, i_ref=i_ref, search=search,
                    rerad_a=r_a, rerad_b=r_b, rn16=np.asarray(resp.reply.bits, np.uint8), **common)


def _window_frame(resp, fs_hz: float, t_rel_s: float, n: int) -> sr.StampFrame:
    """The stamped frame of the tag's reply on the n-sample ST window (reply start ``t_rel_s``
    [s] into it): states S1 and levels 0 past the frame, the frame cut at the window's end."""
    frame = sr.stamp_frame(resp.reply.bits, m=resp.m, trext=resp.trext, blf_hz=resp.blf_hz, fs_hz=fs_hz,
                           n_stamp_cycles=st_pair.STAMP_CYCLES, t0_s=t_rel_s,
                           n_settle_cycles=st_pair.STAMP_SETTLE_CYCLES)
    states = np.full(n, sr.STAMP_S1, dtype=np.int8)
    k = min(n, frame.states.size)
    states[:k] = frame.states[:k]
    stamp_levels = np.zeros(n)
    stamp_levels[:k] = frame.levels[:k]
    return replace(frame, states=states, levels=stamp_levels)


def geometric_null_spacing_m(angle_deg: float, d_min_m: float, d_max_m: float, tag_x_m: float,
                             fc_hz: float) -> float:
    """Mean spacing of the nulls along a radial track from its geometry alone [m].

    θ = 2π(R̃ − r)/λ + const (Eq. 3.23) with R̃ the reader–ST and r the tag–ST distance; for
    weak backscatter θ_cancel ≈ π/2, so a null every π of θ, i.e. every λ/2 of ``R̃ − r``:
    ``(d_max − d_min)·(λ/2)/|Δ(R̃ − r)|`` over the track (reader at the origin, tag at
    ``(tag_x_m, 0)``, track at ``angle_deg`` from the tag→reader direction). Near the tag this
    is λ/(2(1 + cos α)) (0°: λ/4, 90°: λ/2); further out R̃ turns (90°: 0.217 m over
    0.04–1 m for the tag at 2 m, not the 0.164 m of the tangent).

    Parameters
    ----------
    angle_deg : float
        Angle of the track from the tag→reader direction [deg].
    d_min_m : float
        Start of the track: distance from the tag [m].
    d_max_m : float
        End of the track: distance from the tag [m].
    tag_x_m : float
        x of the tag (reader at the origin) [m].
    fc_hz : float
        Carrier frequency [Hz].

    Returns
    -------
    float
        Mean null spacing [m]; ``inf`` where ``R̃ − r`` does not change (180°: the ST
        behind the tag on the reader–tag line).
    """
    lam = float(wavelength_m(fc_hz))
    u = np.array([math.cos(math.pi + math.radians(angle_deg)), math.sin(math.pi + math.radians(angle_deg))])

    def path_difference(d):
        p = np.array([tag_x_m, 0.0]) + d * u
        return float(np.hypot(*p)) - d

    dp = abs(path_difference(d_max_m) - path_difference(d_min_m))
    return (d_max_m - d_min_m) * 0.5 * lam / dp if dp > 1e-9 else float("inf")


def sts_in_disc(rng: np.random.Generator, tag_pos_m, n: int, *, radius_m: float, n_antennas: int,
                spacing_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Draw n ST centres uniformly in a horizontal disc around the tag, each with a uniform orientation.

    Parameters
    ----------
    rng : numpy.random.Generator
        Draws radius² (uniform), then angle, then orientation (n each).
    tag_pos_m : ndarray, shape (3,)
        Position of the tag [m].
    n : int
        Number of ST positions.
    radius_m : float
        Radius of the disc [m].
    n_antennas : int
        Antennas of the ST.
    spacing_m : float
        Spacing of the ST's antennas [m].

    Returns
    -------
    centres_m : ndarray, shape (n, 3)
        ST centres [m], at the tag's height.
    orientations_rad : ndarray, shape (n,)
        Azimuth of each antenna pair's axis [rad], uniform in [−π, π).
    antenna_positions_m : ndarray, shape (n, n_antennas, 3)
        The antenna positions [m] (:func:`rfsim.devices.sense_a_tag.st_antenna_positions`).
    """
    r = radius_m * np.sqrt(rng.random(n))
    phi = rng.uniform(-np.pi, np.pi, n)
    orient = rng.uniform(-np.pi, np.pi, n)
    centres = tag_pos_m + np.stack([r * np.cos(phi), r * np.sin(phi), np.zeros(n)], axis=1)
    return centres, orient, st_antenna_positions(centres, n_antennas=n_antennas, spacing_m=spacing_m,
                                                 orientation_rad=orient)


def in_near_field(sa_pos_m, tag_pos_m, fc_hz: float) -> np.ndarray:
    """Tell which ST positions have an antenna in the tag's reactive near field (within λ/2π).

    There the far-field links do not hold.

    Parameters
    ----------
    sa_pos_m : ndarray, shape (N, k, 3)
        ST antenna positions [m].
    tag_pos_m : array_like, shape (3,)
        Position of the tag [m].
    fc_hz : float
        Carrier frequency [Hz] (λ = c/fc).

    Returns
    -------
    ndarray of bool, shape (N,)
        True where an antenna lies within λ/2π of the tag.
    """
    r_tag = np.linalg.norm(sa_pos_m - tag_pos_m, axis=-1)
    return np.any(r_tag < wavelength_m(fc_hz) / (2.0 * math.pi), axis=1)


def radial_track_positions(tag_pos_m, angles_deg, d_m) -> np.ndarray:
    """Return points along radial tracks from the tag, at the tag's height.

    Parameters
    ----------
    tag_pos_m : ndarray, shape (3,)
        Position of the tag [m] (reader at the origin, tag on +x).
    angles_deg : array_like, shape (A,)
        Angles of the tracks from the tag→reader direction [deg].
    d_m : ndarray, shape (D,)
        Distances from the tag [m].

    Returns
    -------
    ndarray, shape (A, D, 3)
        The points [m].
    """
    ang = np.deg2rad(np.asarray(angles_deg))
    base = math.pi  # tag → reader direction (reader at the origin, tag on +x)
    return tag_pos_m + np.stack([np.cos(base + ang)[:, None] * d_m, np.sin(base + ang)[:, None] * d_m,
                                 np.zeros((ang.size, d_m.size))], axis=-1)


def minima_spacing_m(d_m, diff_v) -> tuple[np.ndarray, float]:
    """Find the local minima of |A1 − A2| along a track and their average spacing.

    Parameters
    ----------
    d_m : array_like, shape (D,)
        Positions along the track [m].
    diff_v : array_like, shape (D,)
        |A1 − A2| at those positions [V].

    Returns
    -------
    minima_m : ndarray
        Positions of the interior local minima [m].
    spacing_m : float
        Mean spacing of consecutive minima [m]; NaN with fewer than 2.
    """
    y = np.asarray(diff_v)
    i = np.flatnonzero((y[1:-1] < y[:-2]) & (y[1:-1] <= y[2:])) + 1
    pos = np.asarray(d_m)[i]
    return pos, float(np.mean(np.diff(pos))) if pos.size >= 2 else float("nan")


#: (unit, description) of the per-position columns a scenario of this scene writes: placement
#: (:func:`sts_in_disc`), near field (:func:`in_near_field`) and the exchange (:class:`Exchange`)
SAMPLE_COLUMNS: dict[str, tuple[str, str]] = {
    "st_x_m": ("m", "x of the ST centre, uniform in a disc of geometry.disc_radius_m around the tag"),
    "st_y_m": ("m", "y of the ST centre, uniform in a disc of geometry.disc_radius_m around the tag"),
    "orientation_rad": ("rad", "azimuth of the ST's antenna pair axis SA1->SA2, uniform in [-pi, pi)"),
    "tag_replied": ("1", "the tag powered up, decoded the reader's Query and replied its RN16 in this "
                         "cell and repetition (false: no backscatter to detect)"),
    "narrowband_error": ("1", "largest relative RMS envelope error of applying the ST links narrowband "
                              "(rfsim.protocols.engine.narrowband_rms_error, must stay <= NARROWBAND_TOLERANCE)"),
    "tag_available_power_w": ("W", "CW power available at the tag antenna port during the Query"),
    "tag_chip_power_w": ("W", "power absorbed by the tag chip (available power x power transmission "
                              "coefficient of the chip's unmodulated state)"),
    "rerad_b_abs": ("1", "|r_B| = |A_s - Gamma_B|, magnitude of the tag's re-radiated modulating state"),
    "rerad_a_abs": ("1", "|r_A| = |A_s - Gamma_A|, magnitude of the tag's re-radiated absorbing state"),
    "near_field": ("1", "an ST antenna lies within lambda/(2 pi) = 5.2 cm of the tag (reactive near "
                        "field, where the far-field links do not hold): excluded from the probabilities"),
}


__all__ = ["V_PER_SQRT_W", "SAMPLE_COLUMNS", "TagListeningScene", "pass_tag_pattern", "room", "reader_antenna",
           "tag_antenna", "st_links", "Exchange", "simulate_exchange", "geometric_null_spacing_m",
           "sts_in_disc", "in_near_field", "radial_track_positions", "minima_spacing_m"]
