"""Print the installed versions of the packages the CI log reports, ``pip list`` style.

Usage: ``python .ci/versions.py LABEL`` with the interpreter of the environment to report;
prints one line ``ci: versions (LABEL): numpy 2.4.6, scipy 1.17.1, ...`` and then one
``name version`` line per package.
"""
from __future__ import annotations

import sys
from importlib.metadata import PackageNotFoundError, version

PACKAGES = ("numpy", "scipy", "numba", "llvmlite", "h5py", "matplotlib", "tqdm", "pytest",
            "hypothesis", "xarray", "pandas", "h5netcdf", "dask", "distributed", "filterpy", "crcmod")


def main() -> int:
    label = sys.argv[1] if len(sys.argv) > 1 else sys.prefix
    found = []
    for name in PACKAGES:
        try:
            found.append((name, version(name)))
        except PackageNotFoundError:
            found.append((name, "(not installed)"))
    print(f"ci: versions ({label}, Python {sys.version.split()[0]}): "
          + ", ".join(f"{n} {v}" for n, v in found))
    width = max(len(n) for n, _ in found)
    for name, ver in found:
        print(f"  {name:<{width}} {ver}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
