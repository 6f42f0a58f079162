"""The exciter scene: an RF exciter (:class:`rfsim.devices.exciter.Exciter`, CW) powers passive
tags or sense-a-tags that backscatter on their own schedule
(:class:`rfsim.devices.own_schedule.OwnSchedule`), and listeners with the sense-a-tag receive
chain pick the backscatter up (auris-sense-a-tag.md ch. 5; binary-detection.md §1.11, Geng
ch. 6; wave2-specs.md §X).

Pieces: the exciter's antenna (:func:`exciter_antenna`), the room (:func:`room`: Friis plus the
exponential APDP with the PASS ST-room curves), area-uniform placement in a disc
(:func:`uniform_disc`), receiver noise kT·fs·F at the listeners (:class:`NoiseConfig`), the
single-antenna listener (:func:`single_listener`) and one air step of an exciter, one
broadcasting tag and a batch of listeners (:func:`tag_broadcast_step`); the measured passive tag
(:func:`measured_tag`). Many listeners are one
batched receiver with narrowband links (:mod:`rfsim.scenes.links`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from rfsim.core.config import param
from rfsim.core.errors import ConfigError
from rfsim.core.lazy import lazy_import
from rfsim.devices.exciter import Exciter, ExciterConfig
from rfsim.devices.sense_a_tag_config import SenseATagConfig
from rfsim.devices.tag_chip import PASS_POWER_MARGIN_DB, PowerDependentChip
from rfsim.devices.tag_config import TagConfig
from rfsim.scenes.links import DrawnLinks, add_drawn_link

_antennas = lazy_import("rfsim.channels.antennas")
_small_scale = lazy_import("rfsim.channels.small_scale")
_scene = lazy_import("rfsim.channels.scene")
_noise = lazy_import("rfsim.channels.noise")
_air = lazy_import("rfsim.air.step")
_tag = lazy_import("rfsim.devices.tag")


@dataclass(frozen=True)
class NoiseConfig:
    """Receiver noise at the listening antennas: kT·fs·F per complex sample
    (:func:`rfsim.channels.noise.thermal_noise_power_w` over the simulated bandwidth fs)."""

    enabled: bool = param(True, doc="receiver noise at the listening antennas")
    nf_db: float = param(10.0, lo=0.0, hi=60.0, unit="dB", doc="noise figure; N = kT·fs·F per complex sample")

    def power_w(self, fs_hz: float) -> float:
        """Return the receiver noise power per complex sample, :math:`N = k T f_s F`.

        Parameters
        ----------
        fs_hz : float
            Sample rate, the simulated bandwidth [Hz].

        Returns
        -------
        float
            Noise power per complex sample [W] (:func:`rfsim.channels.noise.thermal_noise_power_w`);
            0 when disabled.
        """
        return float(_noise.thermal_noise_power_w(fs_hz, self.nf_db)) if self.enabled else 0.0


def single_listener() -> SenseATagConfig:
    """Return the listener of the tag-to-tag links: one antenna, no combining.

    Returns
    -------
    rfsim.devices.sense_a_tag_config.SenseATagConfig
        ``n_antennas=1``, ``technique="single"``, the rest default.
    """
    return SenseATagConfig(n_antennas=1, technique="single")


def measured_tag(antenna, *, rng: np.random.Generator, tag: TagConfig = TagConfig(),
                 margin_db: float = PASS_POWER_MARGIN_DB):
    """Return the passive tag of the exciter scenes.

    The tag has the PASS UCODE-class chip
    (:meth:`rfsim.devices.tag_chip.PowerDependentChip.pass_default`: power-up at picmin +
    ``margin_db``, reflection states following its absorbed power) and re-radiates
    Γ·incident (``structural_mode`` 0); the rest of ``tag`` as given.

    Parameters
    ----------
    antenna : rfsim.channels.antennas.Antenna
        The tag's antenna.
    rng : numpy.random.Generator
        The tag's own stream.
    tag : rfsim.devices.tag_config.TagConfig, optional
        The tag's settings (default ``TagConfig()``); ``structural_mode`` is replaced by 0.
    margin_db : float, optional
        Power-up threshold above the chip's picmin [dB], default
        :data:`rfsim.devices.tag_chip.PASS_POWER_MARGIN_DB`.

    Returns
    -------
    rfsim.devices.tag.PassiveTag
        The tag at ``antenna``.
    """
    return _tag.PassiveTag(dataclasses.replace(tag, structural_mode=0.0), antenna, rng=rng,
                           chip=PowerDependentChip.pass_default(margin_db=margin_db))


def exciter_antenna(kind: str, gain_dbi: float, height_m: float):
    """Return the exciter's antenna at (0, 0, ``height_m``), linearly polarized.

    Parameters
    ----------
    kind : str
        ``"patch"``: a patch with 70° beamwidth and boresight +x; any other value: a
        vertical half-wave dipole.
    gain_dbi : float
        The patch's gain [dBi] (unused for the dipole).
    height_m : float
        Height of the antenna [m].

    Returns
    -------
    rfsim.channels.antennas.Antenna
        The antenna.
    """
    pattern = _antennas.Patch(gain_dbi, 70.0) if kind == "patch" else _antennas.HalfWaveDipole()
    return _antennas.Antenna(position_m=(0.0, 0.0, height_m), orientation=(0.0, 0.0, 0.0), pattern=pattern,
                             polarization="linear")


def room(apdp: bool):
    """Return the channel scene of the exciter scenes: Friis, optionally with small-scale fading.

    Parameters
    ----------
    apdp : bool
        Add the exponential APDP with the PASS ST-room curves
        (:class:`rfsim.channels.small_scale.ApdpModel`).

    Returns
    -------
    rfsim.channels.scene.Scene
        The scene.
    """
    return _scene.Scene(apdp=_small_scale.ApdpModel() if apdp else None)


def uniform_disc(rng: np.random.Generator, n: int, radius_m: float) -> tuple[np.ndarray, np.ndarray]:
    r"""Draw ``n`` points uniformly (by area) in a disc around the origin.

    :math:`r = R \sqrt{u}`, :math:`u \sim U(0, 1)`, :math:`\varphi \sim U(-\pi, \pi)`.

    Parameters
    ----------
    rng : numpy.random.Generator
        Draws the n radii, then the n angles.
    n : int
        Number of points.
    radius_m : float
        Radius R of the disc [m].

    Returns
    -------
    dx_m : ndarray, shape (n,)
        x offsets [m].
    dy_m : ndarray, shape (n,)
        y offsets [m].
    """
    r = radius_m * np.sqrt(rng.random(n))
    phi = rng.uniform(-np.pi, np.pi, n)
    return r * np.cos(phi), r * np.sin(phi)


def tag_broadcast_step(scene, exciter, tag, listeners, *, fc_hz: float, fs_hz: float, n_samples: int,
                       bandwidth_hz: float, noise_power_w: float, link_rng: np.random.Generator,
                       noise_rng: np.random.Generator, keep_components: bool = False):
    """One air step (:func:`rfsim.air.step.propagate`, no decisions) of an exciter, one tag that
    backscatters on its own schedule and a batch of listeners.

    Parameters
    ----------
    scene : rfsim.channels.scene.Scene
        The channel scene (:func:`room`).
    exciter : rfsim.devices.exciter.Exciter
        The exciter.
    tag : rfsim.devices.own_schedule.OwnSchedule
        The reflector, with its ``antenna``.
    listeners : rfsim.scenes.links.BatchAntenna or rfsim.channels.antennas.Antenna
        The listening antennas (a batch, or one antenna).
    fc_hz : float
        Carrier frequency [Hz].
    fs_hz : float
        Sample rate [Hz].
    n_samples : int
        Length of the segment [samples].
    bandwidth_hz : float
        Signal bandwidth that judges the links narrowband [Hz].
    noise_power_w : float
        Receiver noise per complex sample at the listeners [W].
    link_rng : numpy.random.Generator
        Draws the links exciter → tag, exciter → listeners, tag → listeners, in that order.
    noise_rng : numpy.random.Generator
        The step's stream (receiver noise; the exciter's phase noise is the exciter's own).
    keep_components : bool, optional
        Keep the direct and backscatter components of the listeners' input, default False.

    Returns
    -------
    rfsim.air.step.AirResult
        The step's result: ``incident[0]`` at the tag, ``reflections[0]`` its response,
        ``inputs[0]`` (and with ``keep_components`` ``direct[0]``, ``backscatter[0][0]``) at
        the listeners [√W].
    """
    links = DrawnLinks()
    for tx, rx in ((exciter.antenna, tag.antenna), (exciter.antenna, listeners), (tag.antenna, listeners)):
        add_drawn_link(links, scene, tx, rx, fc_hz=fc_hz, rng=link_rng)
    return _air.propagate([exciter], [tag], [_air.AntennaPort(listeners, noise_power_w=noise_power_w)], links,
                          t0_s=0.0, fs_hz=fs_hz, n_samples=n_samples, rng=noise_rng, bandwidth_hz=bandwidth_hz,
                          decide=False, keep_components=keep_components)


def check_exciter_on(exciter: ExciterConfig, *, fs_hz: float, n_samples: int, key: str = "exciter.schedule_s") -> None:
    """Check that the exciter's schedule is on at some sample of the frame's time base.

    A frame with no CW has no backscatter to read. An empty schedule (always on) passes.

    Parameters
    ----------
    exciter : rfsim.devices.exciter.ExciterConfig
        The exciter's settings (``schedule_s``: switching times).
    fs_hz : float
        Sample rate of the frame [Hz].
    n_samples : int
        Length of the frame [samples], from t = 0.
    key : str, optional
        Config key named in the error, default ``"exciter.schedule_s"``.

    Raises
    ------
    rfsim.core.errors.ConfigError
        The schedule is off at every sample of the frame.
    """
    if not exciter.schedule_s:
        return
    t_s = np.arange(int(n_samples)) / float(fs_hz)
    if not Exciter(exciter, None, rng=None).is_on(t_s).any():
        raise ConfigError(key, list(exciter.schedule_s), f"switching times with the exciter on at some time in the "
                                                         f"frame, [0, {n_samples / fs_hz:.6g}) s (on in [t0, t1), "
                                                         f"[t2, t3), …)")


__all__ = ["NoiseConfig", "check_exciter_on", "single_listener", "measured_tag", "exciter_antenna", "room",
           "uniform_disc", "tag_broadcast_step"]
