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
        """Noise power per complex sample [W] (0 when disabled)."""
        return float(_noise.thermal_noise_power_w(fs_hz, self.nf_db)) if self.enabled else 0.0


def single_listener() -> SenseATagConfig:
    """The listener of the tag-to-tag links: one antenna, no combining (``technique="single"``)."""
    return SenseATagConfig(n_antennas=1, technique="single")


def measured_tag(antenna, *, rng: np.random.Generator, tag: TagConfig = TagConfig(),
                 margin_db: float = PASS_POWER_MARGIN_DB):
    """The passive tag of the exciter scenes (:class:`rfsim.devices.tag.PassiveTag` at ``antenna``):
    the PASS UCODE-class chip (:meth:`rfsim.devices.tag_chip.PowerDependentChip.pass_default`,
    power-up at picmin + ``margin_db`` [dB], reflection states following its absorbed power),
    re-radiating Γ·incident (``structural_mode`` 0); the rest of ``tag`` as given."""
    return _tag.PassiveTag(dataclasses.replace(tag, structural_mode=0.0), antenna, rng=rng,
                           chip=PowerDependentChip.pass_default(margin_db=margin_db))


def exciter_antenna(kind: str, gain_dbi: float, height_m: float):
    """The exciter's antenna at (0, 0, ``height_m``) [m]: a patch (``gain_dbi`` [dBi], 70°
    beamwidth) with boresight +x, or (any other ``kind``) a vertical half-wave dipole
    (``rfsim.channels.Antenna``)."""
    pattern = _antennas.Patch(gain_dbi, 70.0) if kind == "patch" else _antennas.HalfWaveDipole()
    return _antennas.Antenna(position_m=(0.0, 0.0, height_m), orientation=(0.0, 0.0, 0.0), pattern=pattern,
                             polarization="linear")


def room(apdp: bool):
    """The channel scene (``rfsim.channels.scene.Scene``): Friis, plus the exponential APDP with
    the PASS ST-room curves when ``apdp``."""
    return _scene.Scene(apdp=_small_scale.ApdpModel() if apdp else None)


def uniform_disc(rng: np.random.Generator, n: int, radius_m: float) -> tuple[np.ndarray, np.ndarray]:
    """n points uniform in a disc of radius ``radius_m`` around the origin: (dx, dy) [m].

    r = R·√u, φ ~ U(−π, π) (area-uniform).
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
    scene : the channel scene (:func:`room`)
    exciter : :class:`rfsim.devices.exciter.Exciter`
    tag : reflector (:class:`rfsim.devices.own_schedule.OwnSchedule`) with its ``antenna``
    listeners : :class:`rfsim.scenes.links.BatchAntenna` (or one antenna)
    fc_hz, fs_hz, n_samples : carrier [Hz], sample rate [Hz] and length of the segment
    bandwidth_hz : signal bandwidth that judges the links narrowband [Hz]
    noise_power_w : receiver noise per complex sample at the listeners [W]
    link_rng : draws the links exciter → tag, exciter → listeners, tag → listeners, in that order
    noise_rng : the step's stream (receiver noise, exciter phase noise is the exciter's own)
    keep_components : keep the direct and backscatter components of the listeners' input

    Returns
    -------
    The step's result: ``incident[0]`` at the tag, ``reflections[0]`` its response,
    ``inputs[0]`` (and with ``keep_components`` ``direct[0]``, ``backscatter[0][0]``) at the
    listeners [√W].
    """
    links = DrawnLinks()
    for tx, rx in ((exciter.antenna, tag.antenna), (exciter.antenna, listeners), (tag.antenna, listeners)):
        add_drawn_link(links, scene, tx, rx, fc_hz=fc_hz, rng=link_rng)
    return _air.propagate([exciter], [tag], [_air.AntennaPort(listeners, noise_power_w=noise_power_w)], links,
                          t0_s=0.0, fs_hz=fs_hz, n_samples=n_samples, rng=noise_rng, bandwidth_hz=bandwidth_hz,
                          decide=False, keep_components=keep_components)


def check_exciter_on(exciter: ExciterConfig, *, fs_hz: float, n_samples: int, key: str = "exciter.schedule_s") -> None:
    """The exciter's schedule is on at some sample of the frame's time base (``n_samples``
    samples at ``fs_hz`` [Hz] from t = 0): a frame with no CW has no backscatter to read, so a
    schedule that never switches on there is a :class:`ConfigError` naming ``key``."""
    if not exciter.schedule_s:
        return
    t_s = np.arange(int(n_samples)) / float(fs_hz)
    if not Exciter(exciter, None, rng=None).is_on(t_s).any():
        raise ConfigError(key, list(exciter.schedule_s), f"switching times with the exciter on at some time in the "
                                                         f"frame, [0, {n_samples / fs_hz:.6g}) s (on in [t0, t1), "
                                                         f"[t2, t3), …)")


__all__ = ["NoiseConfig", "check_exciter_on", "single_listener", "measured_tag", "exciter_antenna", "room",
           "uniform_disc", "tag_broadcast_step"]
