"""What a passive tag did with one reader segment (:class:`TagResponse`): its reply, Γ(t)
and the re-radiation factor r(t) = A_s − Γ(t) it scatters (:mod:`rfsim.devices.tag` module
docstring steps 5–6; Nikitin, Rao & Lam 2006), as a reflection of the air step
(:class:`rfsim.air.step.Reflection`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rfsim.devices.gen2_tag_state import Reply

__all__ = ["REASONS", "TagResponse"]

REASONS = ("", "not powered", "decode error", "no reply")


@dataclass(eq=False)
class TagResponse:
    """What a tag did with one reader segment (a record: treat it as read-only; it is not
    frozen because a population of tags makes one per tag and segment, and a frozen
    dataclass costs six times as much to build).

    Attributes
    ----------
    powered : bool
    command : the parsed command object, or None (not powered / nothing decoded)
    reply : :class:`rfsim.devices.gen2_tag_state.Reply` or None
    gamma : (n,) complex128 or None
        Γ(t) on the time base of the incident segment (sample n at t0_s + n/fs_hz); None
        when the tag does not reply (it then reflects ``gamma_rest`` throughout).
    reply_start_s, reply_end_s : absolute times of the reply [s] (None without reply);
        ``gamma`` holds only the part inside the segment (check ``reply_end_s``).
    blf_hz : the tag's actual BLF [Hz] (None without reply)
    reason : "" (replied), "not powered", "decode error" or "no reply"
    incident_power_dbm : P_inc, mean CW power at the antenna port [dBm] (−inf for silence)
    command_end_s : absolute time of the command's last rising edge [s] or None
    m, trext : line code of the reply (None without reply)
    gamma_rest : Γ_A, the reflection coefficient while not modulating
    structural_mode : A_s, the antenna's structural-mode term (:mod:`rfsim.devices.tag` step 6);
        0 (the default of a bare response) re-radiates −Γ(t)

    ``gamma``, ``gamma_rest`` and :meth:`reflection` are the chip's Γ; the field the tag
    scatters is :meth:`reradiation` times the incident field.
    """

    powered: bool
    command: object | None
    reply: Reply | None
    gamma: np.ndarray | None
    reply_start_s: float | None
    blf_hz: float | None
    reason: str
    incident_power_dbm: float
    command_end_s: float | None = None
    reply_end_s: float | None = None
    m: int | None = None
    trext: bool | None = None
    gamma_rest: complex = 0j
    structural_mode: complex = 0j

    def reflection(self, n_samples: int) -> np.ndarray:
        """Γ(t) over ``n_samples`` samples: :attr:`gamma`, or Γ_A throughout without reply.

        Parameters
        ----------
        n_samples : int
            Samples of the incident segment.

        Returns
        -------
        numpy.ndarray, shape (n_samples,), complex128
            Γ(t) (:attr:`gamma` itself while replying, else a new array).

        Raises
        ------
        ValueError
            If :attr:`gamma` has another length than ``n_samples``.
        """
        if self.gamma is not None:
            if self.gamma.size != n_samples:
                raise ValueError(f"gamma has {self.gamma.size} samples, asked for {n_samples}")
            return self.gamma
        return np.full(int(n_samples), self.gamma_rest, dtype=np.complex128)

    def reradiation(self, n_samples: int) -> np.ndarray:
        """Re-radiation factor ``r(t) = A_s − Γ(t)`` over ``n_samples`` samples.

        The tag scatters r(t)·x_incident(t) [√W] (:mod:`rfsim.devices.tag` step 6; Nikitin,
        Rao & Lam 2006), Γ(t) = :attr:`gamma`, or Γ_A throughout without reply.

        Parameters
        ----------
        n_samples : int
            Samples of the incident segment.

        Returns
        -------
        numpy.ndarray, shape (n_samples,), complex128
            r(t), a new array.

        Raises
        ------
        ValueError
            If :attr:`gamma` has another length than ``n_samples``.
        """
        if self.gamma is not None:
            if self.gamma.size != n_samples:
                raise ValueError(f"gamma has {self.gamma.size} samples, asked for {n_samples}")
            return self.structural_mode - self.gamma
        return np.full(int(n_samples), self.structural_mode - self.gamma_rest, dtype=np.complex128)

    @property
    def reradiation_terms(self) -> tuple[complex, np.ndarray] | None:
        """``(A_s, Γ(t))`` with r(t) = A_s − Γ(t) (:meth:`reradiation`) while the tag replies, else
        None: the air step forms A_s − Γ(t) with the products that follow it in one pass."""
        return None if self.gamma is None else (self.structural_mode, self.gamma)

    @property
    def constant_reradiation(self) -> complex | None:
        """r = A_s − Γ_A when the tag does not reply (constant over the segment), else None."""
        return None if self.gamma is not None else self.structural_mode - self.gamma_rest

    @property
    def scatters(self) -> bool:
        """False only when the re-radiated field is identically zero (no reply and A_s = Γ_A)."""
        return self.gamma is not None or self.structural_mode != self.gamma_rest
