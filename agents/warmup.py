"""Compile and cache the numba kernels: ``python -m agents.warmup`` (``make install`` runs it).

The kernels are compiled on their first call and cached beside their modules (``cache=True``), so
the first episode of a new installation waits for the compiler (most of a minute) and later ones
do not.  This plays one episode of every structure in every mode, with noise, a relay, a pulse and
a PRBS, so that every kernel an episode can reach is compiled once, here, with one line saying so,
instead of inside a user's first run; and the batched feasibility figures of the oracle's fast search.
"""

from __future__ import annotations

import sys
import time

import numpy as np

__all__ = ["warm_up"]


def warm_up() -> float:
    """Play the episodes; the seconds they took."""
    import gymnasium as gym

    import envs  # noqa: F401  (registers the ids)
    from envs.analysis.feasibility import feasibility_margins
    from envs.interface import tuning_env_of

    started = time.perf_counter()
    cases = [(structure, mode, {}) for structure in ("PID", "FPPI", "MSP") for mode in ("fixed", "plan")]
    cases += [(structure, "agent", {"experiment_set": "all", "budget": 5}) for structure in ("PID", "FPPI", "MSP")]
    cases += [("FPPI", "agent", {"experiment_set": "all", "budget": 5, "identification": "least-squares"})]
    for structure, mode, extra in cases:
        env = gym.make(f"DeadTime/{structure}-v3", experiments=mode, noise_std=0.05, **extra)
        env.reset(seed=0)
        done, step = False, 0
        while not done:
            action = np.zeros(env.action_space.shape, dtype=np.float32)
            if mode == "agent":  # each experiment type once, then commit
                action[:] = -1.0
                action[1 + step if step < len(tuning_env_of(env).experiment_names) else 0] = 1.0
            _, _, done, _, _ = env.step(action)
            step += 1
    episode = tuning_env_of(env).episode  # the oracle's fast search's batched feasibility figures
    feasibility_margins(episode.plant, [episode.controller], gain_margin=True, screen=2.0)
    return time.perf_counter() - started


def main() -> int:
    print("compiling the simulation kernels (numba; once per installation, about a minute) ...", file=sys.stderr, flush=True)
    print(f"compiled and cached in {warm_up():.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
