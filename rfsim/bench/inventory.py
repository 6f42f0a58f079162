"""Benchmark of the inventory: a sample-level inventory of N tags to completion, and the
Q algorithm's slots and air time to read all N tags at protocol level."""

from __future__ import annotations

import math
import os
import time

import numpy as np

from rfsim.protocols.inventory import EngineAir, InventoryConfig, ProtocolAir, run_inventory
from rfsim.core.rng import trial_rng


def _circle(n: int, seed: int) -> EngineAir:
    """n tags on a 2 m circle around an isotropic reader in free space (equal powers)."""
    from rfsim.channels import Antenna, Channel, Isotropic, Scene
    from rfsim.devices.reader import Reader, ReaderConfig
    from rfsim.devices.tag import TagConfig
    from rfsim.scenes.room_inventory import make_tags, tag_antenna

    ra = Antenna(position_m=(0.0, 0.0, 1.0), orientation=(0.0, 0.0, 0.0), pattern=Isotropic(),
                 polarization="circular")
    ants = [tag_antenna((2.0 * math.cos(a), 2.0 * math.sin(a), 1.0), a + math.pi)
            for a in 2 * math.pi * np.arange(n) / n]
    tags = make_tags(TagConfig(), ants, seed=seed, key=(0,))
    reader = Reader(ReaderConfig(), [ra], rng=trial_rng(seed, 1))
    return EngineAir(reader, tags, Channel(Scene()), rng=trial_rng(seed, 2))


class _Counted:
    """An air interface that counts the exchanges (reader commands) run through it, and times
    each one (CPU time [s]) by command, and apart those at a new carrier (the first after a
    frequency hop)."""

    def __init__(self, air):
        self.air, self.link, self.n_commands = air, air.link, 0
        self.cpu_s: dict[str, list[float]] = {}
        self.hop_cpu_s: list[float] = []
        self._fc_hz = None

    def exchange(self, cmd, **kw):
        self.n_commands += 1
        c0 = time.process_time()
        ex = self.air.exchange(cmd, **kw)
        cpu_s = time.process_time() - c0
        if ex.fc_hz != self._fc_hz:
            self._fc_hz = ex.fc_hz
            self.hop_cpu_s.append(cpu_s)
        else:
            self.cpu_s.setdefault(type(cmd).__name__, []).append(cpu_s)
        return ex


def bench_inventory(n_tags: int = 100, *, sample_populations: tuple[int, ...] = (10, 50, 100, 200, 500, 1000),
                    populations: tuple[int, ...] = (10, 50, 100, 200), runs: int = 50, seed: int = 0) -> dict:
    """Time sample-level Q-algorithm inventories to completion, and count protocol-level slots.

    Sample level: n tags on a 2 m circle around an isotropic reader in free space (equal
    powers). numba's kernels are loaded on a 3- and a 20-tag inventory first; the 1-minute load
    average is recorded before and after. Protocol level: the Q algorithm's slots and air time
    to read all N tags over ``runs`` populations (:class:`rfsim.protocols.inventory.ProtocolAir`
    over the tags' state arrays, ``miller4-320k``).

    Parameters
    ----------
    n_tags : int, default 100
        Population of the headline sample-level inventory.
    sample_populations : tuple of int, default (10, 50, 100, 200, 500, 1000)
        Populations N of the sample-level inventories.
    populations : tuple of int, default (10, 50, 100, 200)
        Populations N of the protocol-level runs.
    runs : int, default 50
        Protocol-level runs per population.
    seed : int, default 0
        Root seed.

    Returns
    -------
    dict
        ``sample_…`` of the ``n_tags`` inventory (wall and CPU time [s], slots, air time [s],
        tags read, air time per wall second); per sample population N (``sample_N<n>_…``): wall
        and CPU time [s], slots, reader commands, tags read, air time [s], ``…_air_per_wall``
        (> 1: faster than the air), CPU time per command [ms] and per tag and command [µs], the
        carriers used (``…_carriers``: the first command and every first command after a
        frequency hop) and the CPU time of those commands (``…_carrier_cpu_s`` [s]; the median
        one after a hop per tag, ``…_carrier_cpu_per_tag_us`` [µs], NaN without a hop), the CPU
        time per command of the other
        commands (``…_other_cpu_per_command_ms`` [ms]), and per command name the median CPU time
        of the other commands
        (``…_median_cpu_ms_<Query|QueryRep|QueryAdjust|ACK|NAK>`` [ms]). How
        the cost grows with N: ``sample_cpu_exponent``, the slope of log(CPU time) against log(N)
        (1 = linear), ``sample_cpu_per_command_exponent``, the slope of log(CPU time per command)
        against log(N) (0 = flat: the number of commands grows with N on its own, with the Q
        algorithm's draws), and the fit CPU/command = a + b·N as ``sample_cpu_per_command_ms``
        (a, the per-command cost) and ``sample_cpu_per_tag_command_us`` (b, what each further tag adds to
        a command). Per protocol population N (``N<n>_…``): mean ± std of slots and air time [s]
        to read all N tags, the mean efficiency N/slots and the CPU time per slot of these runs
        (``N<n>_cpu_per_slot_us`` [µs]). ``load_average_1min`` and
        ``load_average_1min_after``.
    """
    from rfsim.devices.gen2_tag_arrays import StateArrays
    from rfsim.devices.gen2_tag_state import TagState
    from rfsim.gen2.link import profile

    run_inventory(_circle(3, seed + 1), InventoryConfig())  # warm-up (compilation / cache load)
    run_inventory(_circle(20, seed + 2), InventoryConfig())
    out = {"load_average_1min": os.getloadavg()[0]}
    fit = []
    for n in dict.fromkeys((int(n_tags), *(int(k) for k in sample_populations))):
        air = _Counted(_circle(n, seed))
        t0, c0 = time.perf_counter(), time.process_time()
        log = run_inventory(air, InventoryConfig())
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        if n == n_tags:
            out.update({"sample_n_tags": n_tags, "sample_wall_s": wall, "sample_cpu_s": cpu,
                        "sample_slots": log.n_slots, "sample_air_time_s": log.air_time_s,
                        "sample_tags_read": len(log.tags_read()),
                        "sample_air_time_per_wall_s": log.air_time_s / wall})
        if n in sample_populations:
            k = air.n_commands
            out.update({f"sample_N{n}_wall_s": wall, f"sample_N{n}_cpu_s": cpu, f"sample_N{n}_slots": log.n_slots,
                        f"sample_N{n}_commands": k, f"sample_N{n}_tags_read": len(log.tags_read()),
                        f"sample_N{n}_air_time_s": log.air_time_s, f"sample_N{n}_air_per_wall": log.air_time_s / wall,
                        f"sample_N{n}_cpu_per_command_ms": 1e3 * cpu / k,
                        f"sample_N{n}_cpu_per_tag_command_us": 1e6 * cpu / (k * n),
                        f"sample_N{n}_carriers": len(air.hop_cpu_s),
                        f"sample_N{n}_carrier_cpu_s": float(sum(air.hop_cpu_s)),
                        f"sample_N{n}_carrier_cpu_per_tag_us":
                            1e6 * float(np.median(air.hop_cpu_s[1:])) / n if len(air.hop_cpu_s) > 1 else math.nan,
                        f"sample_N{n}_other_cpu_per_command_ms":
                            1e3 * (cpu - float(sum(air.hop_cpu_s))) / max(1, k - len(air.hop_cpu_s))})
            out.update({f"sample_N{n}_median_cpu_ms_{name}": 1e3 * float(np.median(v))
                        for name, v in sorted(air.cpu_s.items())})
            fit.append((n, cpu, k))
    if len(fit) >= 2:
        n_arr, cpu_arr, k_arr = (np.array(v, float) for v in zip(*fit))
        out["sample_cpu_exponent"] = float(np.polyfit(np.log(n_arr), np.log(cpu_arr), 1)[0])
        out["sample_cpu_per_command_exponent"] = float(np.polyfit(np.log(n_arr), np.log(cpu_arr / k_arr), 1)[0])
        b, a = np.polyfit(n_arr, cpu_arr / k_arr, 1)
        out["sample_cpu_per_command_ms"] = 1e3 * float(a)
        out["sample_cpu_per_tag_command_us"] = 1e6 * float(b)
    out["load_average_1min_after"] = os.getloadavg()[0]
    link = profile("miller4-320k")
    for n in populations:
        slots, air_s, n_slots, cpu_s = [], [], 0, 0.0
        for r in range(runs):
            states = [(TagState(f"{k + 1:024X}"), trial_rng(seed, 10 + n, r, k)) for k in range(n)]
            c0 = time.process_time()
            log = run_inventory(ProtocolAir(link, states, arrays=StateArrays), InventoryConfig())
            cpu_s += time.process_time() - c0
            n_slots += log.n_slots
            done = log.completion(n)
            slots.append(done[0])
            air_s.append(done[1])
        s, a = np.array(slots, float), np.array(air_s)
        out.update({f"N{n}_slots_mean": s.mean(), f"N{n}_slots_std": s.std(ddof=1),
                    f"N{n}_efficiency_mean": float(np.mean(n / s)),
                    f"N{n}_air_time_mean_s": a.mean(), f"N{n}_air_time_std_s": a.std(ddof=1),
                    f"N{n}_cpu_per_slot_us": 1e6 * cpu_s / n_slots})
    return out


__all__ = ["bench_inventory"]
