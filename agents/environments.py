"""The one factory of the environments that ``agents`` trains, evaluates and benchmarks.

:func:`make_env` registers the DeadTime ids first (a worker process, spawned, has not imported
``envs``), makes the environment with its keyword arguments, refuses an unknown id in one line
naming the closest and the known ones (:func:`require_registered`; also ``gymnasium.make``'s own
arguments of the wrong type, and a ``render_mode`` the environment cannot render itself), and with
``oracle=True`` adds the oracle's figures to the final ``info``
(:class:`agents.evaluation.oracle_info.OracleInfo`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["known_env_ids", "make_env", "require_registered"]


def known_env_ids() -> list[str]:
    """The registered DeadTime ids, sorted."""
    import gymnasium

    import envs  # noqa: F401  (registers the DeadTime ids)

    return sorted(key for key in gymnasium.registry if key.startswith("DeadTime/"))


def require_registered(env_id: str, name: str = "environment") -> None:
    """Refuse an id that is not registered with Gymnasium, in one line naming the closest DeadTime id
    (letter case ignored) and the known ones.

    Raises
    ------
    ValueError
        ``unknown environment 'DeadTime/PID-v9' (did you mean 'DeadTime/PID-v3'?); known: ...``
        (``name`` in place of ``environment``).
    """
    import difflib

    import gymnasium

    known = known_env_ids()
    if isinstance(env_id, str) and (env_id in gymnasium.registry or ":" in env_id):
        return  # "module:Id-v0": gymnasium imports the module, which registers the id, and reports on it itself
    lowered = {key.lower(): key for key in known}
    close = difflib.get_close_matches(str(env_id).lower(), list(lowered), n=1)
    hint = f" (did you mean {lowered[close[0]]!r}?)" if close else ""
    raise ValueError(f"unknown {name} {env_id!r}{hint}; known: {', '.join(known) or 'none'}")


def make_env(env_id: str, env_kwargs: Mapping[str, Any] | None = None, *, oracle: bool = False) -> Any:
    """``gymnasium.make(env_id, **env_kwargs)``, the DeadTime ids registered; a ``ValueError`` for an
    unknown id; wrapped in ``OracleInfo`` if ``oracle``."""
    import gymnasium

    require_registered(env_id)
    _check_make_arguments(env_kwargs or {})
    try:
        env = gymnasium.make(env_id, **dict(env_kwargs or {}))
    except (gymnasium.error.Error, ImportError) as error:  # a deprecated version; "module:Id-v0" of no such module
        raise ValueError(f"environment {env_id!r}: {error}") from None
    except TypeError as error:  # an argument the environment does not take (its constructor's message names it)
        raise ValueError(f"environment arguments of {env_id}: {error}") from None
    _check_render_mode(env, env_id, env_kwargs)
    if oracle:
        from agents.evaluation.oracle_info import OracleInfo

        env = OracleInfo(env)
    return env


_MAKE_FLAGS = ("disable_env_checker", "autoreset", "apply_api_compatibility")
"""Arguments of ``gymnasium.make`` itself that take true or false (it does not check them)."""


def _check_make_arguments(env_kwargs: Mapping[str, Any]) -> None:
    """The arguments ``gymnasium.make`` takes for itself: ``max_episode_steps`` null or an integer >= 1, the flags booleans."""
    steps = env_kwargs.get("max_episode_steps")
    if steps is not None and (not isinstance(steps, int) or isinstance(steps, bool) or steps < 1):
        raise ValueError(f"max_episode_steps must be null or an integer >= 1, got {steps!r}")
    for name in _MAKE_FLAGS:
        if name in env_kwargs and not isinstance(env_kwargs[name], bool):
            raise ValueError(f"{name} must be true or false, got {env_kwargs[name]!r}")


def _check_render_mode(env: Any, env_id: str, env_kwargs: Mapping[str, Any] | None) -> None:
    """Refuse a ``render_mode`` the environment does not render itself: ``gymnasium.make`` would wrap it
    (``human`` in ``HumanRendering``, which needs pygame at the first reset)."""
    requested = (env_kwargs or {}).get("render_mode")
    modes = env.unwrapped.metadata.get("render_modes", [])
    if requested is not None and requested not in modes:
        env.close()
        raise ValueError(f"render_mode: {env_id} renders {', '.join(map(repr, modes)) or 'nothing'}, got {requested!r}")
