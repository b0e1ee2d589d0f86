"""Root spectrogram of a two-component chirp: a time-varying AR(6) model over the STFT.

The test signal of the reference implementation: fs = 16 kHz, T = 2¹⁴ samples,

    y[t] = sin(2π f₁(t) t) + sin(2π f₂(t) t) + e[t],   e[t] ~ N(0, 0.01²),

with f₁ rising linearly from 2000 to 2500 Hz over the record (instantaneous
frequency d/dt (f₁(t) t) from 2000 to 3000 Hz) and
f₂ = 5000 + 200 sin(2π n / T) Hz (n the sample index). A time-varying AR(6)
model is fitted with ``norm="sq"``, λ² = 1e5, for difference orders 1 and 2
(:func:`ltvmodels.fit_ar`); the frequencies of its poles over time (the root
spectrogram) are drawn over :func:`scipy.signal.spectrogram` with the
instantaneous frequency of the first component dashed. Prints the mean
distance between that frequency and the nearest pole track, and the fit times.
Headless and seeded.

Usage::

    python examples/chirp_spectrogram.py [--out chirp_spectrogram.png] [--seed 0] [--quick]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from matplotlib.figure import Figure
from scipy.signal import spectrogram

import ltvmodels as ltv

FS = 16000.0
LAM = float(np.sqrt(1e5))  # λ² = 1e5


def chirp(T: int, fs: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The two-component chirp y (T,) and the first component's instantaneous frequency (T,)."""
    rng = np.random.default_rng(seed)
    n = np.arange(T)
    t = n / fs
    f1 = np.linspace(2000.0, 2500.0, T)
    f2 = 5000.0 + 200.0 * np.sin(2 * np.pi * n / T)
    y = np.sin(2 * np.pi * f1 * t) + np.sin(2 * np.pi * f2 * t) + 0.01 * rng.standard_normal(T)
    return y, 2000.0 + 1000.0 * n / (T - 1)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="chirp_spectrogram.png",
                        help="image file to write (default: chirp_spectrogram.png)")
    parser.add_argument("--seed", type=int, default=0, help="noise seed (default: 0)")
    parser.add_argument("--quick", action="store_true",
                        help="a shorter record (T = 2^12) for a fast check")
    args = parser.parse_args(argv)

    T = 2**12 if args.quick else 2**14
    y, inst = chirp(T, FS, args.seed)
    f_stft, t_stft, power = spectrogram(y, fs=FS, nperseg=256, noverlap=192)
    power_db = 10 * np.log10(power + 1e-12)

    fig = Figure(figsize=(10.0, 4.0), layout="constrained")
    axes = fig.subplots(1, 2, sharey=True)
    for ax, order in zip(axes, (1, 2), strict=True):
        start = time.perf_counter()
        model = ltv.fit_ar(y, na=6, lam=LAM, norm="sq", order=order)
        elapsed = time.perf_counter() - start
        freq = model.root_spectrogram(FS)
        target = inst[model.sample_index]
        error = float(np.mean(np.nanmin(np.abs(freq - target[:, None]), axis=1)))
        print(f"order {order}: mean error {error:.2f} Hz between the instantaneous frequency "
              f"and the nearest pole track; fit of T = {T} samples in {elapsed:.3f} s")
        ax.pcolormesh(t_stft, f_stft, power_db, cmap="Greys", shading="auto",
                      vmin=power_db.max() - 80, vmax=power_db.max())
        ltv.plotting.plot_root_spectrogram(model, FS, ax=ax)
        ax.plot(np.arange(T) / FS, inst, color="C3", linestyle="--", linewidth=1.0,
                label="instantaneous frequency")
        ax.set_title(f"AR(6), order {order}, λ² = 1e5: mean error {error:.1f} Hz")
        ax.legend(loc="upper left", fontsize="small", markerscale=6)
    axes[1].set_ylabel("")
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
