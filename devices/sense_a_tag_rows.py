"""The sense-a-tag's detection of a known tag reply in many listenings at once.

Each listening is the ST antennas' inputs from the listening start (the sample after the
reader command, :func:`rfsim.devices.sense_a_tag.listen_start_sample`) and the reply the tag
sent in it. The receive chains of every listening run as the rows of one
:func:`rfsim.devices.sense_a_tag.chain_rows` call per link setting (row by row the same filters
from the same start states as one listening alone); then every row is decoded on its own
(:func:`rfsim.devices.sense_a_tag.decode_rows`: the decoded bits equal the reply's) and the
technique decides (auris-sense-a-tag.md §1.5-1.6, seed 003 L2854-3289): ``single`` reads SA2
(the full ST path), ``combination`` the sum SA1 + SA2 before the detector (§1.5), ``selection``
SA2 else SA1 (Algorithm 1, L3182-3196, :func:`rfsim.devices.st_analytic.select_detected`).
"""

from __future__ import annotations

import math

import numpy as np

from rfsim.devices import sense_a_tag as _sat
from rfsim.devices.sense_a_tag_config import SenseATagConfig
from rfsim.devices.st_analytic import select_detected
from rfsim.gen2.linecode import reply_waveform

#: Outcome of a listening in which the tag did not reply (nothing to decode).
NOT_DETECTED = {"st_detected": False, "st_detected_sa2": False, "st_detected_sa1": False, "st_diff_sa2_v": 0.0}


def chain_names(config: SenseATagConfig) -> list[str]:
    """Name the receive chains one listening runs, in row order.

    Parameters
    ----------
    config : SenseATagConfig
        The ST (number of antennas, technique).

    Returns
    -------
    list of str
        ``"sa2"``, then with two antennas ``"sa1"`` and, for the combination technique,
        ``"combined"`` (SA1 + SA2).
    """
    two = config.n_antennas == 2
    return ["sa2"] + (["sa1"] + (["combined"] if config.technique == "combination" else []) if two else [])


def detect_replies(config: SenseATagConfig, listenings: list, *, t1_max_s: float) -> list[dict]:
    """Whether the ST decodes the known reply of each listening, with its technique.

    Parameters
    ----------
    config : SenseATagConfig
        The ST (technique, antennas, threshold, detector gain).
    listenings : list of tuple
        ``(inputs, tx, response, bits)`` per listening: ``inputs`` (n_antennas, n)
        complex128 [√W], SA1 (, SA2) from the listening start; ``tx`` the reader's segment
        (``fs_hz``, ``t0_s``, ``cmd_end_s``); ``response`` the tag's
        :class:`rfsim.devices.tag.TagResponse` (``blf_hz``, ``m``, ``trext``, ``reply_start_s``,
        ``reply.bits``); ``bits`` the reply's bits, None when the tag did not reply
        (``inputs`` then unused).
    t1_max_s : float
        Keyword-only: the link's largest T1 [s]; the preamble is searched up to T1 max + 2/BLF
        after the listening start.

    Returns
    -------
    list of dict
        One per listening: ``st_detected`` (the technique's outcome), ``st_detected_sa2``,
        ``st_detected_sa1`` (each path alone), ``st_diff_sa2_v`` (sample-level envelope
        difference |A(+1) − A(−1)| at SA2's detector [V]); :data:`NOT_DETECTED` where the tag
        did not reply.
    """

    names = chain_names(config)
    groups: dict = {}  # (BLF, M, TRext, fs, samples) -> indices of the listenings with a reply
    for k, (y, tx, resp, bits) in enumerate(listenings):
        if bits is not None:
            groups.setdefault((resp.blf_hz, resp.m, resp.trext, tx.fs_hz, y.shape[1]), []).append(k)
    chains: dict = {}
    for (blf, m, trext, fs, _), ks in groups.items():
        rx = _sat.make_receiver(config, fs_hz=fs, blf_hz=blf, m=m, trext=trext)
        rows = []
        for k in ks:
            y = listenings[k][0]
            rows.append(y[-1:])
            if len(names) > 1:
                rows.append(y[:1])
                if config.technique == "combination":
                    rows.append(y[:1] + y[-1:])
        env, bp, cmp, tog = _sat.chain_rows(rx, np.concatenate(rows))
        for j, k in enumerate(ks):
            sl = slice(j * len(names), (j + 1) * len(names))
            chains[k] = (rx, env[sl], bp[sl], cmp[sl], tog[sl])
    return [dict(NOT_DETECTED) if bits is None else
            _decode(config, chains[k], names, y.shape[1], tx, resp, bits, t1_max_s)
            for k, (y, tx, resp, bits) in enumerate(listenings)]


def _decode(config: SenseATagConfig, chain: tuple, names: list, n: int, tx, resp, bits, t1_max_s: float) -> dict:
    """Decoding of one listening's chain outputs (rows ``names``, ``n`` samples from the
    listening start; every row decoded on its own) and the technique's outcome."""
    fs = tx.fs_hz
    rx, env, bp, cmp, tog = chain
    i0 = _sat.listen_start_sample(tx.cmd_end_s, t0_s=tx.t0_s, fs_hz=fs)
    out = dict(NOT_DETECTED)
    search = int(math.ceil((t1_max_s + 2.0 / resp.blf_hz) * fs))
    levels = reply_waveform(resp.reply.bits, m=resp.m, trext=resp.trext, blf_hz=resp.blf_hz, fs_hz=fs,
                            t0_s=resp.reply_start_s - i0 / fs, n_samples=n)
    out["st_diff_sa2_v"] = float(np.abs(_sat.level_differences(env[:1], levels, rx))[0])  # row 0: SA2
    ok = _sat.decode_rows(rx, env, bp, cmp, tog, rows=np.ones(len(names), bool), expected_bits=bits,
                          start_sample=0, search_samples=search)
    dec = {name: bool(ok[j]) for j, name in enumerate(names)}
    out["st_detected_sa2"] = dec["sa2"]
    out["st_detected_sa1"] = dec.get("sa1", False)
    if config.technique == "single" or config.n_antennas != 2:
        out["st_detected"] = dec["sa2"]
    elif config.technique == "combination":
        out["st_detected"] = dec["combined"]
    else:
        out["st_detected"] = bool(select_detected(np.array([dec["sa1"]]), np.array([dec["sa2"]]))[0])
    return out


__all__ = ["NOT_DETECTED", "chain_names", "detect_replies"]
