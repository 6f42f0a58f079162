"""Channel benchmarks: link draws per second and the cost of applying a link to a waveform."""

from __future__ import annotations

import time

import numpy as np


def bench_channels(*, n_links: int = 2000, n_samples: int = 1_000_000, n_paths: int = 50,
                   seed: int = 0) -> dict:
    """Measure the channel hot paths on the calling thread (one core).

    Compile time is excluded (one warm-up call each).

    Parameters
    ----------
    n_links : int, default 2000
        Link draws timed.
    n_samples : int, default 1_000_000
        Length of the waveform a link is applied to.
    n_paths : int, default 50
        Paths of the applied link.
    seed : int, default 0
        Seed of the positions, the taps and the waveform.

    Returns
    -------
    dict
        ``link_draws_per_s``: full link draws per second — LoS + first-order image paths of a
        6-surface 8 m × 6 m × 3 m room + freshly drawn APDP taps (PASS room curves) — for random
        tag positions, with ``mean_paths_per_link``;
        ``apply_<n_paths>_paths_<n_samples>_samples_<case>_s`` [s]: time to apply the link to the
        waveform at 4 MS/s, case ``static`` (all paths static), ``7_dopplers`` (LoS + 6
        reflections with their own Doppler shifts, diffuse taps sharing the LoS Doppler: a moving
        tag in that room), ``all_dopplers`` (every path its own Doppler: worst case) and
        ``narrowband``; ``los_links_per_s``: vectorised LoS responses (``los_links``, 10⁶ links).
    """
    # imported here: rfsim does not import channels at module level (DESIGN.md layout)
    from rfsim.channels.antennas import Antenna, HalfWaveDipole
    from rfsim.channels.paths import PathSet, apply_paths
    from rfsim.channels.scene import Channel, Scene, los_links
    from rfsim.channels.small_scale import ApdpModel
    from rfsim.channels.surfaces import Surface

    fc, fs = 915e6, 4e6
    rng = np.random.default_rng(seed)
    room = (
        Surface([0, 0, 0], [0, 0, 1], eps_r=5.3), Surface([0, 0, 3], [0, 0, 1], eps_r=5.3),
        Surface([0, 0, 0], [1, 0, 0], eps_r=5.3), Surface([8, 0, 0], [1, 0, 0], eps_r=5.3),
        Surface([0, 0, 0], [0, 1, 0], eps_r=5.3), Surface([0, 6, 0], [0, 1, 0], eps_r=5.3),
    )
    ch = Channel(Scene(surfaces=room, apdp=ApdpModel(), image_order=1))
    reader = Antenna([0.5, 3.0, 2.0], pattern=HalfWaveDipole())
    tags = [Antenna(p) for p in rng.uniform([1, 1, 0.5], [7, 5, 2.5], (n_links, 3))]
    ch.link(reader, tags[0], fc_hz=fc, rng=rng)
    t = time.perf_counter()
    n_total = 0
    for tag in tags:
        n_total += ch.link(reader, tag, fc_hz=fc, rng=rng).n_paths
    dt_links = time.perf_counter() - t

    x = np.exp(2j * np.pi * rng.uniform(size=n_samples))
    gains = (rng.standard_normal(n_paths) + 1j * rng.standard_normal(n_paths)) * 1e-2
    delays = 10e-9 + rng.uniform(0, 300e-9, n_paths)
    out = {
        "link_draws_per_s": n_links / dt_links,
        "mean_paths_per_link": n_total / n_links,
    }
    cases = {
        "static": np.zeros(n_paths),
        "7_dopplers": np.concatenate([rng.uniform(-10, 10, 7), np.zeros(n_paths - 7)]),
        "all_dopplers": rng.uniform(-10, 10, n_paths),
    }
    for name, dop in cases.items():
        if name == "7_dopplers":
            dop[7:] = dop[0]
        paths = PathSet(gains, delays, dop)
        apply_paths(x[:1000], fs_hz=fs, fc_hz=fc, paths=paths)
        t = time.perf_counter()
        apply_paths(x, fs_hz=fs, fc_hz=fc, paths=paths)
        out[f"apply_{n_paths}_paths_{n_samples}_samples_{name}_s"] = time.perf_counter() - t
    paths = PathSet(gains, delays, cases["all_dopplers"])
    t = time.perf_counter()
    apply_paths(x, fs_hz=fs, fc_hz=fc, paths=paths, method="narrowband")
    out[f"apply_{n_paths}_paths_{n_samples}_samples_narrowband_s"] = time.perf_counter() - t

    n_bulk = 1_000_000
    rx = rng.uniform([1, 1, 0.5], [7, 5, 2.5], (n_bulk, 3))
    t = time.perf_counter()
    los_links(reader.position_m, rx, fc)
    out["los_links_per_s"] = n_bulk / (time.perf_counter() - t)
    return out


def bench_bulk_links(*, n_links: int = 100_000, repeats: int = 3, seed: int = 0) -> dict:
    """Measure full link draws per second of :func:`rfsim.channels.bulk.draw_links` (one core).

    The scene of :func:`bench_channels`: a half-wave dipole reader in a 6-surface
    8 m × 6 m × 3 m room, ``n_links`` random tag positions, each link with LoS + 6 first-order
    image slots + the APDP taps (PASS room curves), drawn in one call. The best of ``repeats``
    calls is reported (one warm-up call first).

    Parameters
    ----------
    n_links : int, default 100_000
        Links drawn per call.
    repeats : int, default 3
        Timed calls (at least one).
    seed : int, default 0
        Seed of the positions and the draws.

    Returns
    -------
    dict
        ``bulk_links_per_s`` (best call), ``paths_per_link`` (the columns per link) and
        ``image_slot_fill`` (the fraction of image slots that hold a path).
    """
    from rfsim.channels.antennas import Antenna, HalfWaveDipole
    from rfsim.channels.bulk import draw_links
    from rfsim.channels.scene import Scene
    from rfsim.channels.small_scale import ApdpModel
    from rfsim.channels.surfaces import Surface

    fc = 915e6
    rng = np.random.default_rng(seed)
    room = (
        Surface([0, 0, 0], [0, 0, 1], eps_r=5.3), Surface([0, 0, 3], [0, 0, 1], eps_r=5.3),
        Surface([0, 0, 0], [1, 0, 0], eps_r=5.3), Surface([8, 0, 0], [1, 0, 0], eps_r=5.3),
        Surface([0, 0, 0], [0, 1, 0], eps_r=5.3), Surface([0, 6, 0], [0, 1, 0], eps_r=5.3),
    )
    scene = Scene(surfaces=room, apdp=ApdpModel(), image_order=1)
    reader = Antenna([0.5, 3.0, 2.0], pattern=HalfWaveDipole())
    tags = rng.uniform([1, 1, 0.5], [7, 5, 2.5], (int(n_links), 3))
    draw_links(scene, reader.position_m, tags[:1000], fc_hz=fc, rng=rng, tx_antenna=reader)
    best = np.inf
    for _ in range(max(int(repeats), 1)):
        t = time.perf_counter()
        out = draw_links(scene, reader.position_m, tags, fc_hz=fc, rng=rng, tx_antenna=reader)
        best = min(best, time.perf_counter() - t)
    n_img = out.n_image_slots
    return {
        "bulk_links_per_s": n_links / best,
        "paths_per_link": out.n_paths,
        "image_slot_fill": float(out.valid[:, 1:1 + n_img].mean()),
    }


__all__ = ["bench_channels", "bench_bulk_links"]
