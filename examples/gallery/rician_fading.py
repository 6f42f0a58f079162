"""A Rician fading draw: the gain of a link while people move in the room.

:func:`rfsim.channels.rician_gains` draws h(t) with a constant part (K factor) and a Jakes-
correlated diffuse part (Clarke 1968; 3 Hz Doppler is 1 m/s at 915 MHz). Writes
``rician_fading.png`` with |h|² in dB for three K factors.
"""

from __future__ import annotations

import numpy as np

from rfsim.channels import rician_gains
from rfsim.core.plots import pyplot
from rfsim.core.rng import trial_rng

from _common import arguments


def main() -> None:
    args = arguments(__doc__.splitlines()[0])
    times_s = np.linspace(0.0, 2.0 if args.small else 5.0, 200 if args.small else 500)
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 3.5))
    for k, k_db in enumerate((0.0, 6.0, 15.0)):
        h = rician_gains(times_s, doppler_hz=3.0, k_db=k_db, rng=trial_rng(1, k))
        ax.plot(times_s, 10 * np.log10(np.abs(h) ** 2), label=f"K = {k_db:g} dB")
        print(f"K = {k_db:4.1f} dB: mean |h|² = {np.mean(np.abs(h) ** 2):.2f}")
    ax.set(xlabel="time [s]", ylabel="|h|² [dB]", title="Rician gain, Doppler 3 Hz")
    ax.legend()
    fig.tight_layout()
    path = args.out / "rician_fading.png"
    fig.savefig(path, dpi=90)
    print(f"figure: {path}")


if __name__ == "__main__":
    main()
