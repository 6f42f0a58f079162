"""Trial batching: B independent exchanges in one pass, each as a separate run would give it.

A Monte Carlo over exchanges (a link budget's read rate, a detection probability, a BER
curve) runs many *independent trials* of the same kind of exchange: the same devices and
command, a different channel draw, receiver noise and tag RN16 in every trial. Link-level
simulators batch such trials along a leading array dimension so that the per-call cost is
paid once per batch (Sionna's convention); here :func:`run_exchanges` does the same for the
sample-level exchange (:func:`rfsim.protocols.engine.run_exchanges`, of which
:func:`rfsim.protocols.engine.run_exchange` is the batch of one), on the air step
(:func:`propagate_batch`, :mod:`rfsim.air.batch`, runs B prepared steps of
:func:`rfsim.air.step.propagate`, :class:`AirStep`, for other callers):

1. per trial b the reader's segment (made once when every trial sends the same command at
   the same time and round), the tags' links drawn from the trial's own generator ``rngs[b]``
   (as the single run draws them, in the same order) and the tags' reactions;
2. the trial's receiver noise, drawn from ``rngs[b]`` (:mod:`rfsim.air.noise`: a key of the
   counter-based stream, or every sample with ``noise="pcg64"``) after its link draws — 1 and 2 are the air step :func:`rfsim.air.step.propagate`, of which only
   the ground truth and the reader's input are kept;
3. the reader's reads of the trials with a reply (:meth:`rfsim.devices.reader.Reader.receive`);
   the consecutive trials read by one reader for one reply kind are read in one call, each
   trial with its own command, listen start and carrier (the RN16s of a Query, the EPC replies
   of the trials' own ACKs; :meth:`rfsim.devices.reader.Reader.receive_batch`: the receive
   kernel on each window, for the sample-level receiver at the nominal BLF; trial by trial
   otherwise), each read as its own;
4. the records (:class:`rfsim.protocols.engine.Exchange`), as the single run forms them.

Each stage runs over a block of :data:`BLOCK` trials in a row (this bounds the memory of a
large batch: a reader input per trial of the block).

Each trial's record is bit-identical to ``run_exchange`` with the same devices and
``rng = rngs[b]`` (tests/test_batch.py: the one implementation, run as a batch of B or as B
batches of one): the same numbers are drawn from the same streams in the same order, and every floating-point operation of the air step is the same
elementwise operation (the noise is added as ``y.real += a; y.imag += b`` there too).
Reproducibility follows the rule of :mod:`rfsim.core.rng`: trial b's stream is its own spawned
generator (e.g. ``trial_rng(seed, point, b)``), so a trial's result does not depend on the
batch it ran in, nor on B.

The order of the draws of a batch of air steps: :mod:`rfsim.air.batch`.

Held links. With ``draw_channel=False`` a trial's links come from its own ``link_caches[b]``
(the draw of its Query, for the ACK); a link missing there is the channel's held draw, and a
channel holds one draw per antenna pair, the last trial's: trials whose tags share antenna
objects need their link caches filled (as :func:`singulate_batch` fills them) or a channel
each.

A reader keeps no state between the trials of a batch when its ``blf_search`` is "off"
(the default); with a BLF search the RN16's BLF is kept for the EPC reply that follows, so
:func:`singulate_batch` then needs one reader per trial.
"""

from __future__ import annotations

from rfsim.air.batch import AirStep, propagate_batch
from rfsim.protocols.engine import BLOCK, run_exchanges, singulate_batch

__all__ = ["AirStep", "BLOCK", "propagate_batch", "run_exchanges", "singulate_batch"]
