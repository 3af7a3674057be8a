"""Fingerprint of seeded episodes of each id and mode: hash of observations, rewards, info costs.

Usage: python /tmp/rn_fingerprint.py OUT.json  (N episodes per id and mode, seeds 0..N-1,
actions from a seeded numpy Generator, uniform over the action space)."""
import hashlib, json, sys
import numpy as np
import gymnasium as gym
import envs  # noqa: F401

N = int(sys.argv[2]) if len(sys.argv) > 2 else 100
out = {}
for env_id in ("DeadTime/PID-v0", "DeadTime/FPPI-v0", "DeadTime/MSP-v0"):
    for mode in ("fixed", "agent"):
        env = gym.make(env_id, experiments=mode)
        rng = np.random.default_rng(12345)
        for seed in range(N):
            h = hashlib.sha256()
            obs, info = env.reset(seed=seed)
            h.update(np.asarray(obs).tobytes())
            done = False
            while not done:
                a = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
                obs, r, term, trunc, info = env.step(a)
                h.update(np.asarray(obs).tobytes()); h.update(np.float64(r).tobytes())
                done = term or trunc
            for k in sorted(info):
                v = info[k]
                if isinstance(v, (float, int, np.floating)):
                    h.update(f"{k}={float(v)!r}".encode())
            score = info.get("score")
            h.update(repr(sorted((k, repr(v)) for k, v in (vars(score) if hasattr(score, "__dict__") else dict(score or {})).items())).encode())
            out[f"{env_id}|{mode}|{seed}"] = h.hexdigest()
json.dump(out, open(sys.argv[1], "w"), indent=0)
print(len(out), "episodes")
