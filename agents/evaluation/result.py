"""The outcome of one policy on one plant (:class:`PolicyResult`), as the evaluation scores and caches it."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any

__all__ = ["FAILURE_COST", "PolicyResult"]


FAILURE_COST = 26.0
"""The cost charged for a failure: that of an unstable loop (``FEASIBLE_CAP + 1 + UNSTABLE_GRADE``)."""


@dataclass(frozen=True)
class PolicyResult:
    """The outcome of one policy on one plant.

    ``controller`` is the controller's JSON (``None`` on failure); ``parameter`` the dimensionless
    design parameter where the policy has one (``mu``, ``T_r/T_n`` or ``T_r/L_n``, as the agent's
    and the oracle's), else ``None``; ``error`` the failure's message; ``choice`` a selector's chosen
    candidate (left out of :meth:`to_dict` for every other policy).
    """

    cost: float
    feasible: bool
    failure: bool
    experiment_time: float
    controller: dict[str, Any] | None = None
    parameter: float | None = None
    error: str | None = None
    choice: str | None = None

    def to_dict(self) -> dict[str, Any]:
        data = asdict(self)
        if data["choice"] is None:
            del data["choice"]
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> PolicyResult:
        """The result of :meth:`to_dict`'s object.

        Raises
        ------
        ValueError
            If ``data`` is not such an object (a key missing or unknown, a value of the wrong type,
            a cost that is not a finite number), naming the field.
        """
        if not isinstance(data, dict):
            raise ValueError(f"a result must be an object, got {type(data).__name__}")
        names = [field.name for field in fields(cls)]
        unknown = sorted(set(data) - set(names))
        if unknown:
            raise ValueError(f"unknown field {unknown[0]!r} of a result")
        for name in names[:4]:
            if name not in data:
                raise ValueError(f"a result needs {name!r}")
        _check(data)
        return cls(**data)

    @classmethod
    def failed(cls, error: Exception, experiment_time: float) -> PolicyResult:
        return cls(FAILURE_COST, False, True, experiment_time, error=str(error))


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _check(data: dict[str, Any]) -> None:
    """Refuse the first field of a result's object whose value has the wrong type."""
    checks = {
        "cost": lambda v: _number(v) and math.isfinite(v),
        "feasible": lambda v: isinstance(v, bool),
        "failure": lambda v: isinstance(v, bool),
        "experiment_time": _number,
        "controller": lambda v: v is None or isinstance(v, dict),
        "parameter": lambda v: v is None or _number(v),
        "error": lambda v: v is None or isinstance(v, str),
        "choice": lambda v: v is None or isinstance(v, str),
    }
    for name, valid in checks.items():
        if name in data and not valid(data[name]):
            raise ValueError(f"{name} of a result is {data[name]!r}")
