"""NoCaptureAir: a slot with two or more replies is never decoded; others pass unchanged."""

from __future__ import annotations

from typing import NamedTuple

from rfsim.protocols.no_capture import NoCaptureAir


class _Ex(NamedTuple):
    """The fields of an exchange record (rfsim.protocols.inventory.AirExchange, a named tuple) read here."""

    replied: tuple
    detected: bool
    success: bool = True
    bits: tuple | None = (1, 0)
    failure_reason: str = ""


class _Air:
    link = "a link"

    def __init__(self, ex):
        self.ex, self.calls = ex, []

    def exchange(self, cmd, **kw):
        self.calls.append((cmd, kw))
        return self.ex


def test_two_detected_replies_become_a_collision():
    air = _Air(_Ex(replied=(0, 1), detected=True))
    wrapped = NoCaptureAir(air)
    ex = wrapped.exchange("Query", t_s=1.0)
    assert (ex.success, ex.bits, ex.failure_reason) == (False, None, "collision")
    assert air.calls == [("Query", {"t_s": 1.0})] and wrapped.link == "a link"


def test_single_or_undetected_replies_pass_unchanged():
    for ex in (_Ex(replied=(0,), detected=True), _Ex(replied=(0, 1), detected=False), _Ex(replied=(), detected=False)):
        assert NoCaptureAir(_Air(ex)).exchange("ACK") is ex
