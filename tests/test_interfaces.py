"""The protocol layers use devices and the channel only through declared interfaces
(:mod:`rfsim.protocols.interfaces`), and the devices provide them.

Two checks that can fail independently:

* an AST scan of the protocol modules: every attribute they read from a reader, a tag or a
  channel (by the names those modules give them) is a member of the matching protocol — a new,
  undeclared use (as ``reader.config.blf_search`` was) fails here;
* every member of a protocol exists on the device class that implements it (as a method, a
  property or an attribute set on construction), and each declared method's keyword parameters
  are accepted by the device's method.
"""

from __future__ import annotations

import ast
import inspect
import typing
from pathlib import Path

import numpy as np
import pytest

from rfsim.channels import Antenna, Channel, Scene
from rfsim.core.rng import trial_rng
from rfsim.devices import PassiveTag, Reader, ReaderConfig, TagConfig
from rfsim.devices.active_tag import ActiveTag, ActiveTagConfig
from rfsim.protocols import interfaces as itf

ROOT = Path(__file__).resolve().parents[1]

#: In each protocol module, the local names bound to a device or the channel → their protocol.
BINDINGS = {
    "engine.py": {"reader": itf.Gen2Reader, "channel": itf.Gen2Channel},
    "bistatic.py": {"reader": itf.Gen2Reader, "channel": itf.Gen2Channel},
    "inventory.py": {"reader": itf.Gen2Reader, "channel": itf.Gen2Channel, "tag": itf.Gen2Tag},
    "batch.py": {"reader": itf.Gen2Reader},
    "beacons.py": {"tag": itf.BeaconTag},
}
#: Loop variables over sequences of devices: (module, variable, iterable name) → protocol.
LOOPS = {("engine.py", "r", "readers"): itf.Gen2Reader}


def _members(proto) -> set[str]:
    names = set(getattr(proto, "__annotations__", {}))
    names |= {n for n, v in vars(proto).items() if callable(v) and not n.startswith("_")}
    return names


def _nested(proto, attr):
    ann = typing.get_type_hints(proto).get(attr)
    return ann if isinstance(ann, type) and issubclass(ann, typing.Protocol) else None


def _uses(path: Path, bindings: dict, loops: dict, source: str | None = None) -> list[tuple[type, tuple[str, ...]]]:
    """(protocol, attribute chain) for every attribute read on a bound name in ``path``."""
    tree = ast.parse(source if source is not None else path.read_text(encoding="utf-8"))
    bound = dict(bindings)
    for node in ast.walk(tree):
        if isinstance(node, (ast.For, ast.comprehension)) and isinstance(node.target, ast.Name) \
                and isinstance(node.iter, ast.Name) and (path.name, node.target.id, node.iter.id) in loops:
            bound[node.target.id] = loops[(path.name, node.target.id, node.iter.id)]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute):
            chain, v = [node.attr], node.value
            while isinstance(v, ast.Attribute):
                chain.insert(0, v.attr)
                v = v.value
            if isinstance(v, ast.Name) and v.id in bound:
                out.append((bound[v.id], tuple(chain)))
    return out


def _undeclared(uses) -> set[str]:
    bad = set()
    for proto, chain in uses:
        head = chain[0]
        if head not in _members(proto):
            bad.add(f"{proto.__name__}.{'.'.join(chain)}")
            continue
        inner = _nested(proto, head)
        if inner is not None and len(chain) > 1 and chain[1] not in _members(inner):
            bad.add(f"{proto.__name__}.{'.'.join(chain)}")
    return bad


def test_the_scan_sees_the_uses():
    uses = [u for name in BINDINGS for u in _uses(ROOT / "rfsim" / "protocols" / name, BINDINGS[name], LOOPS)]
    chains = {(p.__name__, c) for p, c in uses}
    assert ("Gen2Reader", ("transmit",)) in chains
    assert ("Gen2Reader", ("config", "blf_search")) in chains  # the once-undeclared edge (the batched singulation in engine.py)
    assert ("BeaconTag", ("send",)) in chains


@pytest.mark.parametrize("module", sorted(BINDINGS))
def test_protocol_modules_read_only_declared_members(module):
    uses = _uses(ROOT / "rfsim" / "protocols" / module, BINDINGS[module], LOOPS)
    assert _undeclared(uses) == set()


def test_an_undeclared_read_is_caught():
    src = "def f(reader):\n    return reader.config.blf_search + reader.config.tx_gain + reader.secret()\n"
    uses = _uses(Path("x.py"), {"reader": itf.Gen2Reader}, {}, source=src)
    assert _undeclared(uses) == {"Gen2Reader.config.tx_gain", "Gen2Reader.secret"}


def _devices():
    ant = Antenna(position_m=(0.0, 0.0, 1.0))
    reader = Reader(ReaderConfig(), [ant], rng=trial_rng(1, 0))
    tag = PassiveTag(TagConfig(), Antenna(position_m=(1.0, 0.0, 1.0)), rng=trial_rng(1, 1))
    beacon = ActiveTag(ActiveTagConfig(), Antenna(position_m=(2.0, 0.0, 1.0)), rng=trial_rng(1, 2))
    return {itf.Gen2Reader: reader, itf.Gen2Tag: tag, itf.Gen2Channel: Channel(Scene()), itf.BeaconTag: beacon}


@pytest.mark.parametrize("proto", [itf.Gen2Reader, itf.Gen2Tag, itf.Gen2Channel, itf.BeaconTag],
                         ids=lambda p: p.__name__)
def test_devices_provide_every_declared_member(proto):
    device = _devices()[proto]
    assert isinstance(device, proto)
    for name in _members(proto):
        assert hasattr(device, name), f"{type(device).__name__} lacks {name}"
        inner = _nested(proto, name)
        if inner is not None:
            for sub in _members(inner):
                assert hasattr(getattr(device, name), sub), f"{type(device).__name__}.{name} lacks {sub}"
        declared = vars(proto).get(name)
        if callable(declared):
            want = [p for p in inspect.signature(declared).parameters.values()
                    if p.name != "self" and p.kind is p.KEYWORD_ONLY]
            have = inspect.signature(getattr(device, name)).parameters
            var_kw = any(p.kind is p.VAR_KEYWORD for p in have.values())
            missing = [p.name for p in want if p.name not in have and not var_kw]
            assert missing == [], f"{type(device).__name__}.{name} does not take {missing}"


def test_reader_settings_say_whether_the_reader_keeps_state():
    assert ReaderConfig().blf_search in ("off", "preamble")
    assert np.isfinite(_devices()[itf.Gen2Reader].noise_power_w())
