"""Write a pip constraints file that pins every declared dependency to its lower bound.

Reads ``pyproject.toml`` (stdlib ``tomllib`` only) and, for every requirement of
``[project].dependencies`` and of the optional-dependency groups named on the command
line (default: ``test``), writes ``name==X`` where the requirement says ``name>=X``
(also ``~=X`` or ``==X``). ``pip install -c <file> -e ".[test]"`` then installs the
oldest versions the project claims to support, so CI can check the claim.

Pins beyond the declared names
------------------------------
* An extra of a dependency that is itself a separately versioned package in lock-step
  is pinned to the same version: ``dask[distributed]>=2024.1`` gives ``dask==2024.1.0``
  and ``distributed==2024.1.0`` (``distributed`` only asks for ``dask`` of its own
  version, but ``dask[distributed]`` alone would let pip pick a newer pair).
* ``llvmlite`` is not pinned: every numba release requires one llvmlite minor series
  (numba 0.62.0 -> llvmlite 0.45.*), so pinning numba fixes llvmlite up to a bug-fix
  release (pip takes that series' newest, e.g. 0.45.1).
* Other transitive packages (pandas under xarray, packaging, ...) are left to pip, which
  picks the newest release the pinned packages allow. That is what a user who installs
  at the floors gets, so a floor that breaks with today's transitive releases is a floor
  to raise.

Usage: ``python .ci/lower_bounds.py [-o FILE] [EXTRA ...]`` (prints to stdout without -o).
"""
from __future__ import annotations

import argparse
import re
import sys
import tomllib
from pathlib import Path

# Extras whose name is a package released in lock-step with its parent.
LOCKSTEP_EXTRAS = {("dask", "distributed")}

_REQ = re.compile(r"^\s*([A-Za-z0-9][A-Za-z0-9._-]*)\s*(?:\[([^\]]*)\])?\s*([^;]*?)\s*(?:;.*)?$")
_SPEC = re.compile(r"^\s*(>=|~=|==)\s*([0-9][0-9A-Za-z.+!-]*)\s*$")


def _normalise(name: str) -> str:
    """PEP 503 normalised project name."""
    return re.sub(r"[-_.]+", "-", name).lower()


def _padded(version: str) -> str:
    """``2024.1`` -> ``2024.1.0`` (a release number of at least three parts, for lock-step pins)."""
    parts = version.split(".")
    return ".".join(parts + ["0"] * (3 - len(parts))) if all(p.isdigit() for p in parts) else version


def lower_bound(requirement: str) -> tuple[str, list[str], str]:
    """Return ``(name, extras, lowest version)`` of one PEP 508 requirement string.

    Raises
    ------
    ValueError
        When the requirement declares no lower bound (``>=``, ``~=`` or ``==``).
    """
    m = _REQ.match(requirement)
    if not m:
        raise ValueError(f"cannot parse requirement {requirement!r}")
    name, extras, specs = m.group(1), m.group(2), m.group(3)
    floor = None
    for spec in filter(None, (s.strip() for s in specs.split(","))):
        s = _SPEC.match(spec)
        if s:
            floor = s.group(2)
    if floor is None:
        raise ValueError(f"{requirement!r} declares no lower bound")
    return _normalise(name), [_normalise(e) for e in (extras or "").split(",") if e.strip()], floor


def constraints(pyproject: dict, extras: list[str]) -> dict[str, str]:
    """Map every declared package (and lock-step extra) to its pinned lowest version."""
    reqs = list(pyproject["project"].get("dependencies", []))
    optional = pyproject["project"].get("optional-dependencies", {})
    for extra in extras:
        reqs += optional[extra]
    pins: dict[str, str] = {}
    for req in reqs:
        name, req_extras, floor = lower_bound(req)
        if name in pins and pins[name] != floor:
            raise ValueError(f"{name}: two different lower bounds ({pins[name]}, {floor})")
        pins[name] = floor
        for extra in req_extras:
            if (name, extra) in LOCKSTEP_EXTRAS:
                pins[name] = pins[extra] = _padded(floor)
    return pins


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("extras", nargs="*", default=["test"])
    parser.add_argument("-o", "--output", type=Path)
    parser.add_argument("--pyproject", type=Path, default=Path(__file__).resolve().parent.parent / "pyproject.toml")
    args = parser.parse_args(argv)
    with open(args.pyproject, "rb") as f:
        pins = constraints(tomllib.load(f), args.extras)
    text = "# Lowest declared versions, generated from pyproject.toml by .ci/lower_bounds.py\n"
    text += "".join(f"{name}=={version}\n" for name, version in sorted(pins.items()))
    if args.output:
        args.output.write_text(text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
