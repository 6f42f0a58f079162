"""An air interface with capture switched off: the protocol level's collision rule on
sample-level waveforms (a comparison baseline for capture at the reader)."""

from __future__ import annotations


class NoCaptureAir:
    """A sample-level air interface whose reader never decodes a slot with two or more replies.

    Capture switched off: the protocol level's collision rule
    (:class:`rfsim.protocols.inventory.ProtocolAir`), judged on the ground truth, on otherwise
    identical waveforms. The slot is detected, not decoded, so the reader does not ACK and
    counts a collision.

    Parameters
    ----------
    air : object
        The wrapped air interface (``link`` and ``exchange(cmd, **kw)`` returning an exchange
        record with ``replied``, ``detected``, ``success``, ``bits``, ``failure_reason``).
    """

    def __init__(self, air):
        self.air, self.link = air, air.link

    def exchange(self, cmd, **kw):
        """Run the wrapped exchange, with no decoding of a slot in which two or more tags replied.

        Parameters
        ----------
        cmd : object
            The command (:mod:`rfsim.gen2.commands`).
        **kw
            Passed on to the wrapped ``exchange``.

        Returns
        -------
        object
            The wrapped exchange record (:class:`rfsim.protocols.inventory.AirExchange`); with ≥ 2 replies and a detected slot a copy with
            ``success=False``, ``bits=None`` and ``failure_reason="collision"``.
        """
        ex = self.air.exchange(cmd, **kw)
        if len(ex.replied) >= 2 and ex.detected:
            return ex._replace(success=False, bits=None, failure_reason="collision")
        return ex


__all__ = ["NoCaptureAir"]
