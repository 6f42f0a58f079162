"""The Python entry point for scripts: a scene of devices and a channel, run round by round.

:class:`Simulation` holds the same objects the scenarios use — a reader
(:class:`rfsim.devices.Reader`), tags (:class:`rfsim.devices.PassiveTag`) and a channel
(:class:`rfsim.channels.Channel` over a :class:`rfsim.channels.Scene`) — and runs them through the
engine (:func:`rfsim.protocols.engine.run_exchange`, :func:`rfsim.protocols.engine.singulate`). It adds no
physics of its own: it keeps the time line, derives one random stream per round from one
seed and collects the engine's :class:`~rfsim.protocols.engine.Exchange` records, which it can hand
back as a table, an :class:`rfsim.core.dataset.Dataset` or an HDF5 file::

    sim = Simulation(reader, [tag], Channel(Scene()), seed=7)
    exchanges = sim.query_round()          # Query → RN16 → ACK → PC+EPC+CRC-16
    table = sim.table()                     # one row per exchange, as NumPy columns
    sim.save("my-run.h5")                   # the same format as 'rfsim run'

Randomness (rfsim.core.rng): round *i* draws its channel and receiver noise from
``trial_rng(seed, i)``; the devices bring their own streams (give them ``trial_rng(seed,
...)`` children of the same seed, as the scenarios do). The core sees the devices only
through the engine's methods, so any object with the same methods joins a scene (other
emitters and listeners — exciters, sense-a-tags — are driven by their own protocol layers
on the same air interface).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from rfsim.core.records import READ_MEASUREMENT_FIELDS
from rfsim.core.rng import trial_rng

#: Columns of :meth:`Simulation.table` (name → (units, description)).
EXCHANGE_FIELDS: dict[str, tuple[str, str]] = {
    "round": ("1", "round of the simulation the exchange belongs to, 0-based"),
    "time_s": ("s", "start of the reader's segment (CW lead-in, then the command)"),
    "command": ("", "reader command of the exchange (Query, ACK, ...)"),
    **READ_MEASUREMENT_FIELDS,
    "success": ("1", "the reader decoded exactly the bits one replying tag sent (CRC ok where there is one)"),
    "failure_reason": ("", "why the exchange failed ('' = success), rfsim.protocols.engine.FAILURE_REASONS"),
    "n_replied": ("1", "tags that replied in the exchange (ground truth)"),
    "tag_incident_power_dbm": ("dBm", "CW power incident at the first tag's antenna port"),
}


class Simulation:
    """A reader, its tags and a channel, run round by round through the engine.

    Parameters
    ----------
    reader : rfsim.devices.Reader
        The reader.
    tags : sequence of rfsim.devices.PassiveTag
        The tags, in the order the records index them.
    channel : rfsim.channels.Channel
        The channel.
    seed : int, default 0
        Root seed; round *i* uses ``trial_rng(seed, i)`` for channel draws and noise.
    round_period_s : float, default 20e-3
        Time between round starts [s] (silent air time is skipped, not sampled).

    Attributes
    ----------
    records : list of rfsim.protocols.engine.Exchange
        Every exchange so far, in order.
    rounds : int
        Rounds run so far.

    Raises
    ------
    ValueError
        ``round_period_s`` not finite and > 0.
    """

    def __init__(self, reader, tags: Sequence, channel, *, seed: int = 0, round_period_s: float = 20e-3):
        if not (math.isfinite(round_period_s) and round_period_s > 0):
            raise ValueError(f"round_period_s must be > 0, got {round_period_s!r}")
        self.reader, self.tags, self.channel = reader, list(tags), channel
        self.seed, self.round_period_s = int(seed), float(round_period_s)
        self.records: list[Any] = []
        self._round_of: list[int] = []
        self.rounds = 0

    def _next_round(self) -> tuple[int, float, np.random.Generator]:
        i = self.rounds
        self.rounds += 1
        return i, i * self.round_period_s, trial_rng(self.seed, i)

    def _keep(self, i: int, exchanges: list) -> list:
        self.records.extend(exchanges)
        self._round_of.extend([i] * len(exchanges))
        return exchanges

    def query_round(self, *, q: int = 0, target: str = "A", session: int = 0, ack: bool = True) -> list:
        """Run one inventory round opened by a Query with the reader's link.

        With ``ack`` (and Q = 0, the tags reply at once) the reader ACKs an RN16 it decoded and
        reads PC+EPC+CRC-16 (:func:`rfsim.protocols.engine.singulate`); otherwise only the Query and
        the RN16 replies (:func:`rfsim.protocols.engine.run_exchange`).

        Parameters
        ----------
        q : int, default 0
            Slot-count parameter Q of the Query (2**Q slots; 0: every tag replies at once).
        target : {"A", "B"}, default "A"
            Inventoried flag the Query selects.
        session : int, default 0
            Session S0–S3 (0–3) whose inventoried flag the round uses.
        ack : bool, default True
            ACK a decoded RN16 and read the EPC.

        Returns
        -------
        list of rfsim.protocols.engine.Exchange
            The round's exchanges (the Query's, and the ACK's when one was sent).

        Notes
        -----
        Calling this in a loop with the same ``target`` reads a tag once, then gets no reply: that
        is Gen2 session behaviour, not a failure of the link. Each tag keeps one inventoried flag
        per session (A or B) and replies only to a Query whose ``target`` equals its flag in the
        Query's ``session``; a tag that was read (its EPC acknowledged) inverts that flag when the
        round ends (A → B), so it stays silent for later Queries targeting A until the flag returns
        to A. In S0 the flag persists while the tag is powered (a tag stays powered from round to
        round as long as each command's CW powers it; the silent time between rounds is skipped,
        not an outage); S1 reverts to A 0.5–5 s after it was set, S2 and S3 persist more than 2 s
        without power (:class:`rfsim.devices.FlagPersistence`). To read a tag again and again,
        alternate the target (``target="AB"[i % 2]`` in round ``i``, the dual-target inventory of
        commercial readers and of the ``link`` scenario), or use S1 with a ``round_period_s``
        longer than its persistence.
        """
        from rfsim.protocols.engine import run_exchange, singulate
        from rfsim.gen2.commands import Query

        link = self.reader.link
        query = Query(dr=link.dr, m=link.m, trext=link.trext, q=q, target=target, session=session)
        i, t_s, rng = self._next_round()
        if ack and q == 0:
            out = singulate(self.reader, self.tags, self.channel, t_s=t_s, rng=rng, query=query, round_index=i)
        else:
            out = [run_exchange(self.reader, self.tags, self.channel, query, t_s=t_s, rng=rng, reply_bits=16,
                                expect_crc=False, round_index=i)]
        return self._keep(i, out)

    def exchange(self, command, *, reply_bits: int, expect_crc: bool) -> Any:
        """Send any Gen2 command as a round of its own.

        Parameters
        ----------
        command : object
            A command of :mod:`rfsim.gen2.commands`.
        reply_bits : int
            Reply length the reader listens for (16 for an RN16, 128 for PC+EPC+CRC-16 with a
            96-bit EPC).
        expect_crc : bool
            Whether the reader checks a CRC-16.

        Returns
        -------
        rfsim.protocols.engine.Exchange
            The exchange's record.
        """
        from rfsim.protocols.engine import run_exchange

        i, t_s, rng = self._next_round()
        ex = run_exchange(self.reader, self.tags, self.channel, command, t_s=t_s, rng=rng,
                          reply_bits=reply_bits, expect_crc=expect_crc, round_index=i)
        return self._keep(i, [ex])[0]

    def table(self) -> dict[str, np.ndarray]:
        """Return every exchange so far, one row each.

        The measurements are NaN where the reader decoded nothing; ``pandas.DataFrame(sim.table())``
        gives the same as a data frame.

        Returns
        -------
        dict of str to ndarray
            The columns of :data:`EXCHANGE_FIELDS` (name → (n_exchanges,) array; antenna 1-based).
        """
        rows: dict[str, list] = {k: [] for k in EXCHANGE_FIELDS}
        for i, ex in zip(self._round_of, self.records):
            read = ex.read
            ok = read is not None and not ex.failure_reason
            values = dict(round=i, time_s=ex.time_s, command=ex.command, antenna=ex.antenna + 1,
                          channel_index=ex.channel_index, frequency_hz=ex.fc_hz,
                          success=not ex.failure_reason, failure_reason=ex.failure_reason,
                          n_replied=len(ex.replied),
                          tag_incident_power_dbm=ex.incident_power_dbm[0] if ex.incident_power_dbm else math.nan)
            for k in ("rssi_dbm", "phase_rad", "doppler_hz", "snr_db"):
                values[k] = getattr(read, k) if ok else math.nan
            for k, v in values.items():
                rows[k].append(v)
        return {k: np.asarray(v) for k, v in rows.items()}

    def to_dataset(self):
        """Return the records as a dataset.

        Returns
        -------
        rfsim.core.dataset.Dataset
            One table ``exchanges`` (:meth:`table`, with the units of :data:`EXCHANGE_FIELDS`) and
            the attribute ``rounds``.
        """
        from rfsim.core.dataset import Dataset, column

        ds = Dataset(title="exchanges of a scripted simulation (rfsim.Simulation)", scenario="script")
        table = self.table()
        ds.add_table("exchanges", {k: column(v, *EXCHANGE_FIELDS[k]) for k, v in table.items()},
                     description="one row per reader command and what came back (rfsim.protocols.engine.Exchange)")
        ds.attrs["rounds"] = self.rounds
        return ds

    def save(self, path: str | Path) -> Path:
        """Write :meth:`to_dataset` atomically to an HDF5 file with provenance (seed, versions).

        Parameters
        ----------
        path : str or pathlib.Path
            The output file (the same format as ``rfsim run``).

        Returns
        -------
        pathlib.Path
            The path written.
        """
        from rfsim.core.dataset import make_provenance, utc_now, write_dataset

        prov = make_provenance(config_toml="", seed=self.seed, scenario="script", start_time_utc=utc_now(),
                               extra={"note": "built in Python with rfsim.Simulation; config_toml is empty"})
        return write_dataset(path, self.to_dataset(), prov)


__all__ = ["Simulation", "EXCHANGE_FIELDS"]
