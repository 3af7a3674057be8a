"""Plants with dead time, ``G(s) e^{-L s}``.

A :class:`Plant` is a rational, proper transfer function ``G(s) = num(s)/den(s)`` (coefficients in
descending powers of ``s``, as in python-control and ``scipy.signal``) in series with a dead time
``L``.  ``G`` is self-regulating (every pole in the open left half plane) or integrating (one pole
at the origin, the others in the open left half plane).  Everything else in deadtime-gym takes a
validated :class:`Plant`; invalid data is refused with a ``ValueError`` that names the field.

The moments used by the method of moments (Gorez-Klan eq. 2-3 .. 2-6 and appendix A) are exact
functions of the coefficients, see :meth:`Plant.taylor_coefficients`.  The coefficients are checked
and their moments computed in :mod:`envs.systems.coefficients`; the state-space realization of ``G``
(:meth:`Plant.state_space`) is built in :mod:`envs.systems.state_space`.
"""

from __future__ import annotations

import reprlib
from dataclasses import dataclass
from functools import cached_property
from typing import Any, Sequence

import numpy as np

from envs.systems.coefficients import MAX_COEFFICIENTS, _as_coefficients, _roots, _taylor_coefficients
from envs.systems.state_space import StateSpace, _balanced, _controllable_form, _read_only, _scaled_controllable_form
from envs.validation import require_dead_time

__all__ = ["Plant", "as_plant", "NEGLIGIBLE_DEAD_TIME", "GAIN_RANGE", "MAX_COEFFICIENTS", "TIME_SCALE_RANGE"]


GAIN_RANGE = (1e-12, 1e12)
"""The documented range of ``|K|`` (static or velocity gain): everything downstream is gain
invariant within it (to rounding; tests/property/test_core_invariants.py); outside it a plant is
refused (``num``), e.g. coefficients of 1e300 whose products overflow."""
TIME_SCALE_RANGE = (1e-12, 1e12)
"""The documented range of the time scale :meth:`Plant.step_time_scale` (``T_ar``), in the plant's
own time unit; outside it a plant is refused (``den``)."""

NEGLIGIBLE_DEAD_TIME = 1e-4
"""Closed-loop simulations (experiments and IAE) take a dead time below this fraction of
:meth:`Plant.step_time_scale` as zero (:attr:`Plant.simulation_dead_time`) instead of sampling finer
than it: the normalized IAE changes by about ``L/T_ar`` (< 1e-4, below the method's own error of
6e-4), while resolving it would need ``T_ar/L`` samples per residence time (at 1e-7, more than
the memory holds).  The frequency-domain analysis always uses the exact dead time."""


@dataclass(frozen=True)
class Plant:
    """A validated plant ``G(s) e^{-L s}``.

    Parameters
    ----------
    num, den : sequence of float
        Numerator and denominator coefficients of ``G`` in descending powers of ``s``.  Leading
        zeros are dropped; the denominator is scaled to be monic.
    dead_time : float
        The dead time ``L >= 0`` (the key ``delay`` of the JSON form, :meth:`from_dict`).

    Raises
    ------
    ValueError
        If a coefficient is not finite, ``G`` is improper, has a pole in the closed right half
        plane other than a single pole at the origin, has zero (static or velocity) gain, the
        dead time is negative or not finite, or the gain or the time scale is outside
        :data:`GAIN_RANGE` or :data:`TIME_SCALE_RANGE`.

    Examples
    --------
    >>> plant = Plant(num=[1.0], den=[10.0, 1.0], dead_time=5.0)
    >>> plant.gain, plant.residence_time
    (1.0, 15.0)
    """

    num: tuple[float, ...]
    den: tuple[float, ...]
    dead_time: float

    def __post_init__(self) -> None:
        num = _as_coefficients(self.num, "num")
        den = _as_coefficients(self.den, "den")
        try:
            if isinstance(self.dead_time, bool | str | bytes):  # numbers to float(), not to Python
                raise TypeError
            dead_time = float(self.dead_time)
        except (TypeError, ValueError, OverflowError):
            raise ValueError(f"dead_time must be a number, got {self.dead_time!r}") from None
        if not np.isfinite(dead_time) or dead_time < 0:
            raise ValueError(f"dead_time must be finite and >= 0, got {self.dead_time!r}")
        if len(num) > len(den):
            raise ValueError(
                f"num has degree {len(num) - 1} > den degree {len(den) - 1}: the plant must be proper"
            )
        scale = den[0]
        num = tuple(v / scale for v in num)
        den = tuple(v / scale for v in den)
        object.__setattr__(self, "num", num)
        object.__setattr__(self, "den", den)
        object.__setattr__(self, "dead_time", dead_time)
        self._validate_poles()
        self._validate_range()

    def _validate_poles(self) -> None:
        den = self.den  # leading coefficient 1: not all zero
        origin_poles = 0
        while den[len(den) - 1 - origin_poles] == 0.0:
            origin_poles += 1
        if origin_poles > 1:
            raise ValueError(f"den has {origin_poles} poles at s=0: at most one integrator is allowed")
        if self.num[-1] == 0.0:
            raise ValueError("num has a zero at s=0: the plant has zero gain")
        poles = _roots(den[: len(den) - origin_poles])
        if poles.size and np.max(poles.real) >= 0.0:
            worst = poles[np.argmax(poles.real)]
            raise ValueError(f"den has an unstable pole at s={worst:.6g}: the plant must be stable or integrating")

    def _validate_range(self) -> None:
        gain, (low, high) = abs(self.gain), GAIN_RANGE
        if not low <= gain <= high:
            raise ValueError(f"num: the plant's gain {self.gain:.6g} is outside the documented range +-[{low:g}, {high:g}]")
        scale, (low, high) = self.step_time_scale(), TIME_SCALE_RANGE
        if not low <= scale <= high:
            field = "dead_time" if self.dead_time > high else "den"
            raise ValueError(f"{field}: the plant's time scale T_ar = {scale:.6g} is outside the documented range [{low:g}, {high:g}]")

    # ----------------------------------------------------------------- constructors
    @classmethod
    def from_time_constants(
        cls,
        gain: float,
        time_constants: Sequence[float],
        dead_time: float = 0.0,
        *,
        zero_time_constants: Sequence[float] = (),
        integrating: bool = False,
    ) -> "Plant":
        """``K prod(1 + T0_j s) / (s^i prod(1 + T_k s)) e^{-L s}``.

        ``zero_time_constants`` holds ``T0_j`` of the numerator factors ``(1 + T0_j s)``; a
        negative value gives a right-half-plane zero, e.g. ``-2`` for ``(1 - 2 s)``.
        """
        gain = float(gain)
        if not np.isfinite(gain) or gain == 0.0:
            raise ValueError(f"gain must be finite and non-zero, got {gain!r}")
        for name, values in (("time_constants", time_constants), ("zero_time_constants", zero_time_constants)):
            if not np.all(np.isfinite(np.asarray(values, dtype=float))):
                raise ValueError(f"{name} must be finite, got {list(values)!r}")
        if any(t <= 0 for t in time_constants):
            raise ValueError(f"time_constants must be > 0, got {list(time_constants)!r}")
        num = np.array([gain])
        for t0 in zero_time_constants:
            num = np.polymul(num, [t0, 1.0])
        den = np.array([1.0])
        for t in time_constants:
            den = np.polymul(den, [t, 1.0])
        if integrating:
            den = np.polymul(den, [1.0, 0.0])
        return cls(num=tuple(num), den=tuple(den), dead_time=dead_time)

    @classmethod
    def from_transfer_function(cls, transfer_function: Any, dead_time: float = 0.0) -> "Plant":
        """From a SISO continuous-time ``control.TransferFunction`` (or anything with its
        ``num``/``den`` layout) and a dead time."""
        if getattr(transfer_function, "ninputs", 1) != 1 or getattr(transfer_function, "noutputs", 1) != 1:
            raise ValueError("transfer_function must be SISO")
        if getattr(transfer_function, "dt", 0) not in (0, None):
            raise ValueError("transfer_function must be continuous time (dt = 0)")
        try:
            num = np.asarray(transfer_function.num[0][0], dtype=float)
            den = np.asarray(transfer_function.den[0][0], dtype=float)
        except (AttributeError, IndexError, TypeError):
            raise ValueError("transfer_function must have num[0][0] and den[0][0] coefficient arrays") from None
        return cls(num=tuple(num), den=tuple(den), dead_time=dead_time)

    @classmethod
    def from_dict(cls, data: Any) -> "Plant":
        """From the JSON form ``{"num": [...], "den": [...], "delay": L}``; a delay of 0 needs relative degree 2
        or more (:func:`envs.validation.require_dead_time`)."""
        if not isinstance(data, dict):
            raise ValueError(f"plant must be a JSON object with num, den, delay; got {type(data).__name__}")
        unknown = sorted(set(data) - {"num", "den", "delay"})
        if unknown:
            raise ValueError(f"plant has unknown key {unknown[0]!r} (expected num, den, delay)")
        for key in ("num", "den", "delay"):
            if key not in data:
                raise ValueError(f"plant is missing key {key!r}")
        num, den = data["num"], data["den"]
        for key, value in (("num", num), ("den", den)):
            if not isinstance(value, list | tuple) or not all(
                isinstance(v, int | float) and not isinstance(v, bool) for v in value
            ):
                raise ValueError(f"plant.{key} must be a list of numbers, got {reprlib.repr(value)}")
        dead_time = data["delay"]
        if not isinstance(dead_time, int | float) or isinstance(dead_time, bool):
            raise ValueError(f"plant.delay must be a number, got {dead_time!r}")
        try:
            plant = cls(num=tuple(num), den=tuple(den), dead_time=dead_time)
        except ValueError as error:  # named by the JSON key: plant.delay, not plant.dead_time
            message = str(error)
            if message.startswith("dead_time"):
                message = "delay" + message[len("dead_time") :]
            raise ValueError(f"plant.{message}") from None
        require_dead_time(plant.dead_time, plant.relative_degree, "plant.delay")
        return plant

    def to_dict(self) -> dict[str, Any]:
        """The JSON form accepted by :meth:`from_dict`."""
        return {"num": list(self.num), "den": list(self.den), "delay": self.dead_time}

    # ----------------------------------------------------------------- properties
    @property
    def relative_degree(self) -> int:
        """Degree of the denominator less that of the numerator (leading zeros dropped)."""
        return len(self.den) - len(self.num)

    @property
    def integrating(self) -> bool:
        """True if ``G`` has a pole at the origin."""
        return self.den[-1] == 0.0

    @property
    def order(self) -> int:
        """Degree of the denominator of ``G``."""
        return len(self.den) - 1

    @property
    def rational_part(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """``(num, den)`` of ``G`` without the integrator (equal to ``(num, den)`` if stable)."""
        return self.num, self.den[:-1] if self.integrating else self.den

    @property
    def gain(self) -> float:
        """Static gain ``K = G(0)``, or the velocity gain ``lim s G(s)`` if integrating."""
        num, den = self.rational_part
        return num[-1] / den[-1]

    def taylor_coefficients(self) -> tuple[float, float]:
        """``(p1, p2)`` of ``P(s)/K = 1 + p1 s + p2 s^2 + ...`` (Gorez-Klan eq. 2-3, appendix A).

        For an integrating plant the expansion is that of ``s P(s)/K_v`` (the dynamics additional
        to the integrator, with the dead time).  Computed once per plant.
        """
        return self._taylor_coefficients

    @cached_property
    def _taylor_coefficients(self) -> tuple[float, float]:
        return _taylor_coefficients(*self.rational_part, self.dead_time)

    @property
    def residence_time(self) -> float:
        """Average residence time ``T_ar = -p1`` (Gorez-Klan eq. 2-5; Ingimundarson eq. 5).

        For an integrating plant, ``T_ar`` of the dynamics additional to the integrator, i.e. the
        dead time ``L_n`` of the two-parameter model (Ingimundarson section 2.1).
        """
        return -self.taylor_coefficients()[0]

    @property
    def simulation_dead_time(self) -> float:
        """The dead time of closed-loop simulations: ``L``, or 0 if ``L < NEGLIGIBLE_DEAD_TIME T``."""
        return self.dead_time if self.dead_time >= NEGLIGIBLE_DEAD_TIME * self.step_time_scale() else 0.0

    # ----------------------------------------------------------------- responses
    def frequency_response(self, omega: np.ndarray | float) -> np.ndarray:
        """Exact ``G(i omega) e^{-i omega L}``."""
        s = 1j * np.asarray(omega, dtype=float)
        return np.polyval(self.num, s) / np.polyval(self.den, s) * np.exp(-s * self.dead_time)

    def state_space(self) -> StateSpace:
        """A well-scaled realization of ``G`` (the dead time is not included).

        The controllable canonical form of ``G`` in normalized time ``s T`` (``T`` from
        :meth:`step_time_scale`), rescaled to the plant's time and balanced, so that the states
        have the magnitude of the signals whatever the plant's time scale.  Computed once per
        plant; the arrays are read-only.
        """
        return self._realization

    @cached_property
    def _realization(self) -> StateSpace:
        if self.order == 0:  # tf2ss would pad a static gain with a dummy state
            gain = np.atleast_2d(self.num[-1] / self.den[-1])
            return _read_only(StateSpace(A=np.zeros((0, 0)), B=np.zeros((0, 1)), C=np.zeros((1, 0)), D=gain))
        scale = self.step_time_scale()
        powers = np.arange(self.order, -1, -1)  # descending powers of s, as in den
        num = np.asarray(self.num) * scale ** -powers[len(powers) - len(self.num) :]
        den = np.asarray(self.den) * scale**-powers
        if abs(num[0] / den[0]) > 1e-14:  # _controllable_form and the division by scale, in one compiled call
            A, B, C, D = _scaled_controllable_form(num, den, scale)
        else:
            A, B, C, D = _controllable_form(num, den)
            A, B = A / scale, B / scale
        A, factors = _balanced(A)
        return _read_only(StateSpace(A=A, B=B / factors[:, None], C=C * factors[None, :], D=np.atleast_2d(D)))

    def step_time_scale(self) -> float:
        """A time scale for simulation: ``T_ar`` if positive, else the slowest time constant."""
        return self._step_time_scale

    @cached_property
    def _step_time_scale(self) -> float:
        t_ar = self.residence_time
        if t_ar > 0:
            return t_ar
        num, den = self.rational_part
        poles = np.roots(den)
        slowest = 1.0 / np.min(np.abs(poles)) if poles.size else 1.0
        return float(max(slowest, self.dead_time, 1e-12))


def as_plant(value: Any, what: str = "plant") -> Plant:
    """A :class:`Plant` from any of the forms a plant is given in.

    Parameters
    ----------
    value : Plant, dict, control.TransferFunction or (TransferFunction, dead_time)
        A plant; its JSON form ``{"num": [...], "den": [...], "delay": L}``
        (:meth:`Plant.from_dict`); a SISO continuous-time python-control ``TransferFunction``
        (no dead time); or a pair of one and its dead time (:meth:`Plant.from_transfer_function`).
        A form given without dead time needs relative degree 2 or more
        (:func:`envs.validation.require_dead_time`); a :class:`Plant` is taken as it is.
    what : str
        The name of the argument in the error message.

    Raises
    ------
    ValueError
        Naming ``what`` and the forms accepted, or the invalid field.

    Examples
    --------
    >>> import control
    >>> as_plant((control.tf([2.0], [4.0, 1.0]), 1.5)).to_dict()  # stored with a monic denominator
    {'num': [0.5], 'den': [1.0, 0.25], 'delay': 1.5}
    """
    if isinstance(value, Plant):
        return value
    if isinstance(value, dict):
        return Plant.from_dict(value)
    if isinstance(value, tuple) and len(value) == 2 and hasattr(value[0], "den"):
        plant = Plant.from_transfer_function(value[0], value[1])
    elif hasattr(value, "num") and hasattr(value, "den"):
        plant = Plant.from_transfer_function(value)
    else:
        raise ValueError(
            f"{what} must be a Plant, a JSON object with num, den, delay, a control.TransferFunction or a "
            f"(TransferFunction, delay) pair; got {type(value).__name__}"
        )
    require_dead_time(plant.dead_time, plant.relative_degree, f"{what}: the dead time")
    return plant
