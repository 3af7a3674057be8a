"""At the sample where each of the fixed procedure's experiments stops, how far is the TRUE output from its
final value, in units of the noise's standard error over one window (``sigma/sqrt(n)``), and how much
does it still change over the last window (in units of the slope test's ``sigma sqrt(12/n)``)?
The 80 FPPI-v0 test plants, plant i with ``numpy.random.default_rng(i)``.  Usage: deadtime study
steady-state.  Results: docs/numerics.md, "Experiment length and noise"."""

from __future__ import annotations

import numpy as np

from envs.identification.procedure import identify
from envs.systems.plant_sets import plant_set


def steady_state() -> None:
    """Print, per noise level and experiment, the median, 90% quantile and maximum of both ratios."""
    plants = plant_set("stable", "test", 80)
    for noise in [0.01, 0.05, 0.1, 0.2]:
        ratios = {"closed": [], "open": []}; slopes = {"closed": [], "open": []}
        for i, plant in enumerate(plants):
            ident = identify(plant, np.random.default_rng(i), noise)
            for name, result, final in (("closed", ident.closed_loop, 1.0), ("open", ident.open_loop, plant.gain * ident.open_loop.height)):
                t = result.timepts; dt = t[1] - t[0]
                tar = plant.step_time_scale() if name == "closed" else ident.residence_time
                n = max(int(round(tar / dt)), 3)
                y = result.true_output[-n:]
                se = noise / np.sqrt(n)
                ratios[name].append(abs(y.mean() - final) / se)
                slope = np.polyfit(np.arange(n), y, 1)[0] * (n - 1)
                slopes[name].append(abs(slope) / (noise * np.sqrt(12.0 / n)))
        for name in ratios:
            r, s = np.array(ratios[name]), np.array(slopes[name])
            print(f"noise {noise:4.2f} {name:6s}: |true mean - final|/(sigma/sqrt n) median {np.median(r):.2f} 90% {np.quantile(r, .9):.2f} max {r.max():.2f} | "
                  f"|true change over window|/(sigma sqrt(12/n)) median {np.median(s):.2f} 90% {np.quantile(s, .9):.2f} max {s.max():.2f}")
