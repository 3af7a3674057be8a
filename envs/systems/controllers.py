"""Controllers: transfer functions for analysis and state-space blocks for simulation.

Every controller is a two-degree-of-freedom law ``u = C_ff(s) r - C_fb(s) y``:

* :class:`PID`, ideal form with derivative filter, ``kp (1 + 1/(ti s) + td s/(1 + td s/n))``
  on the error (``C_ff = C_fb``); ``ti=None`` drops the integral and ``td=0`` the derivative.
* :class:`SeriesPID`, ``kp (1 + 1/(ti s)) (1 + td s)/(1 + td s/n)`` on the error; the form of
  Haalman's and Gorez-Klan's design (eq. 3-11).
* :class:`FPPI`, Hagglund's predictive PI with Normey-Rico's first-order filter
  ``F = 1/(tf s + 1)`` (Ingimundarson section 4, eq. 13-16): a Smith predictor on the FOPDT
  model ``K_n e^{-L_n s}/(T_n s + 1)`` with ``T_i = T_n`` and ``K = T_n/(K_n T_r)`` (eq. 14-15).
* :class:`MSP`, Matausek and Micic's modified Smith predictor for integrating plants
  (Ingimundarson section 5, eq. 35-38, 47): model ``K_n e^{-L_n s}/s``, set-point gain
  ``K_r = 1/(K_n T_r)``, disturbance filter ``F = K_0 = 1/(2 L_n K_n)`` or the PD-type extension
  of eq. 51.

Each class gives ``feedback_response``/``reference_response`` (exact, dead times included) and
``block()``, a :class:`~envs.simulation.delay_systems.DelaySystem` with inputs ``[r, y_measured]`` and output
``u`` whose internal dead times are exact delays.  The tests check that the two agree.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from envs.simulation.delay_systems import DelaySystem
from envs.systems._controllers_kernels import (
    _fppi_matrices,
    _msp_matrices,
    _packed_fppi,
    _packed_msp,
    _packed_rational,
    _rational_matrices,
)
from envs.validation import check_keys, require_number

__all__ = ["PID", "SeriesPID", "FPPI", "MSP", "Controller", "controller_from_dict", "packed_block"]


def _rational_block(num: np.ndarray, den: np.ndarray) -> DelaySystem:
    """A 1-DOF rational controller ``C = num/den`` acting on ``e = r - y``.

    The controller canonical form of ``scipy.signal.tf2ss`` (same arithmetic), without its dummy
    state for a static gain and without its trimming of numerator coefficients below ``1e-14``:
    ``x' = A x + b e``, ``u = c x + d e`` with ``A``'s first row ``-den[1:]/den[0]`` and ones below
    the diagonal, ``b = e_1``, ``c = num[1:] - num[0] den[1:]`` and ``d = num[0]`` (``num`` padded to
    the length of ``den``, both divided by ``den[0]``).  Filled in by one compiled call
    (:func:`~envs.systems._controllers_kernels._rational_matrices`), which costs a few microseconds instead of some twenty numpy calls.
    """
    return DelaySystem(*_rational_matrices(np.ascontiguousarray(num, dtype=float), np.ascontiguousarray(den, dtype=float)))


def _polyadd(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.polyadd`` of coefficient arrays (without its poly1d handling)."""
    size = max(a.size, b.size)
    return np.concatenate([np.zeros(size - a.size), a]) + np.concatenate([np.zeros(size - b.size), b])


@dataclass(frozen=True)
class PID:
    """Ideal PID ``kp (1 + 1/(ti s) + td s/(1 + td s/n))`` on the error (Marlin ch. 8).

    ``ti=None`` means no integral action, ``td=0`` no derivative action (``n`` is then unused).
    """

    kp: float
    ti: float | None
    td: float = 0.0
    n: float = 10.0

    def __post_init__(self) -> None:
        require_number(self.kp, "kp", nonzero=True)
        if self.ti is not None:
            require_number(self.ti, "ti", positive=True)
        require_number(self.td, "td", nonnegative=True)
        if self.td > 0:
            require_number(self.n, "n", positive=True)

    @property
    def integrators(self) -> int:
        return 0 if self.ti is None else 1

    def transfer_function(self) -> tuple[np.ndarray, np.ndarray]:
        """``(num, den)`` in descending powers of ``s``."""
        num, den = np.array([1.0]), np.array([1.0])
        if self.ti is not None:  # 1 + 1/(ti s) = (ti s + 1)/(ti s)
            num, den = np.array([self.ti, 1.0]), np.array([self.ti, 0.0])
        if self.td > 0:  # + td s/(1 + td s/n)
            filt = np.array([self.td / self.n, 1.0])
            num = _polyadd(np.convolve(num, filt), np.convolve(den, [self.td, 0.0]))  # np.polymul is np.convolve
            den = np.convolve(den, filt)
        return self.kp * num, den

    @cached_property
    def _coefficients(self) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`transfer_function`, computed once (the controller is immutable)."""
        return self.transfer_function()

    def feedback_response(self, omega: np.ndarray) -> np.ndarray:
        num, den = self._coefficients
        s = 1j * np.asarray(omega, dtype=float)
        return np.polyval(num, s) / np.polyval(den, s)

    reference_response = feedback_response

    def block(self) -> DelaySystem:
        return _rational_block(*self._coefficients)  # the cached transfer_function()

    def packed_block(self) -> tuple[np.ndarray, int, int]:
        """:func:`packed_block` of :meth:`block`."""
        num, den = self._coefficients
        return _packed_rational(np.ascontiguousarray(num, dtype=float), np.ascontiguousarray(den, dtype=float))

    def to_dict(self) -> dict[str, Any]:
        return {"type": "pid", **self._fields()}

    def _fields(self) -> dict[str, Any]:
        """``dataclasses.asdict(self)`` of the four number fields (without its deep copies)."""
        return {"kp": self.kp, "ti": self.ti, "td": self.td, "n": self.n}


@dataclass(frozen=True)
class SeriesPID:
    """Series (interacting) PID ``kp (1 + 1/(ti s)) (1 + td s)/(1 + td s/n)`` on the error.

    This is the form of Haalman's design and of Gorez-Klan eq. 3-11 (``T_i = T_1``,
    ``T_d = T_2``, ``K_p = T_i/(mu K D_2)``); see :meth:`gorez_klan`.
    """

    kp: float
    ti: float | None
    td: float = 0.0
    n: float = 10.0

    __post_init__ = PID.__post_init__
    integrators = PID.integrators
    _fields = PID._fields

    @classmethod
    def gorez_klan(cls, gain: float, time_constants: tuple[float, float], dead_time: float, mu: float, n: float) -> "SeriesPID":
        """Gorez-Klan design on the SOPDT model ``K e^{-D_2 s}/((1+T_1 s)(1+T_2 s))``.

        ``T_i = T_1``, ``T_d = T_2``, ``K_i = 1/(mu K D_2)``, ``K_p = K_i T_i`` (eq. 3-11), so that
        the model loop is ``e^{-D_2 s}/(mu D_2 s)`` up to the derivative filter (eq. 3-12).

        A degenerate model (``theta = 1``: ``T_1 = T_2 = 0``, which the moments give for plants whose
        normalized dead time is 1 or more, e.g. with a strong inverse response) makes the design a
        pure integral controller ``1/(mu K D_2 s)``; ``T_1`` is then floored at ``1e-9 D_2``, which
        is that controller up to a negligible proportional part.  ``T_2 = 0`` drops the derivative.
        """
        t1, t2 = (require_number(t, f"time_constants[{i}]", nonnegative=True) for i, t in enumerate(time_constants))
        require_number(gain, "gain", nonzero=True)
        require_number(dead_time, "dead_time", positive=True)
        require_number(mu, "mu", positive=True)
        t1 = max(t1, 1e-9 * dead_time)
        return cls(kp=t1 / (mu * gain * dead_time), ti=t1, td=t2, n=n)

    def transfer_function(self) -> tuple[np.ndarray, np.ndarray]:
        num, den = np.array([1.0]), np.array([1.0])
        if self.ti is not None:
            num, den = np.array([self.ti, 1.0]), np.array([self.ti, 0.0])
        if self.td > 0:
            num = np.convolve(num, [self.td, 1.0])  # np.polymul
            den = np.convolve(den, [self.td / self.n, 1.0])
        return self.kp * num, den

    _coefficients = PID._coefficients
    feedback_response = PID.feedback_response
    reference_response = PID.feedback_response
    block = PID.block
    packed_block = PID.packed_block

    def to_dict(self) -> dict[str, Any]:
        return {"type": "pid-series", **self._fields()}


@dataclass(frozen=True)
class FPPI:
    """Filtered predictive PI (Ingimundarson section 4, Fig. 4).

    ``u = C (r - G_n u - F (y - G_n e^{-L_n s} u))`` with ``C = K (1 + 1/(T_i s))``,
    ``G_n = K_n/(T_n s + 1)``, ``F = 1/(T_f s + 1)``, ``T_i = T_n``, ``K = T_n/(K_n T_r)``
    (eq. 13-15).  ``tf = 0`` gives Hagglund's unfiltered PPI.  Characteristic equation eq. 16.

    Attributes
    ----------
    gain, time_constant, dead_time : float
        The FOPDT model ``K_n``, ``T_n``, ``L_n`` (eq. 1).
    tr : float
        Closed-loop time constant ``T_r = T_n/kappa`` (eq. 15).
    tf : float
        Filter time constant ``T_f`` (the design rules set ``T_f = T_r``, section 4.3).
    """

    gain: float
    time_constant: float
    dead_time: float
    tr: float
    tf: float = 0.0

    def __post_init__(self) -> None:
        require_number(self.gain, "model.gain", nonzero=True)
        require_number(self.time_constant, "model.time_constant", positive=True)
        require_number(self.dead_time, "model.dead_time", nonnegative=True)
        require_number(self.tr, "tr", positive=True)
        require_number(self.tf, "tf", nonnegative=True)

    integrators = 1

    @property
    def kappa(self) -> float:
        return self.time_constant / self.tr

    @property
    def proportional_gain(self) -> float:
        return self.time_constant / (self.gain * self.tr)

    def _parts(self, omega: np.ndarray):
        s = 1j * np.asarray(omega, dtype=float)
        c = self.proportional_gain * (1 + 1 / (self.time_constant * s))
        g = self.gain / (self.time_constant * s + 1)
        f = 1 / (self.tf * s + 1)
        loop = 1 + c * g * (1 - f * np.exp(-s * self.dead_time))
        return c, f, loop

    def feedback_response(self, omega: np.ndarray) -> np.ndarray:
        """``C F/(1 + C G_n (1 - F e^{-L_n s}))``."""
        c, f, loop = self._parts(omega)
        return c * f / loop

    def reference_response(self, omega: np.ndarray) -> np.ndarray:
        """``C/(1 + C G_n (1 - F e^{-L_n s}))``."""
        c, f, loop = self._parts(omega)
        return c / loop

    def block(self) -> DelaySystem:
        """``u = K (e + (1/T_i) int e)``, ``e = r - m - c``, with the model output ``m`` (``T_n m' =
        K_n u - m``) and the correction ``c = y - m(t - L_n)``, filtered (``T_f c' = y - m(t - L_n) -
        c``) if ``T_f > 0``: the rows of these equations over ``[int e, m, (c), r, y, (m(t - L_n))]``,
        filled in by one compiled call (:func:`~envs.systems._controllers_kernels._fppi_matrices`)."""
        return DelaySystem(*_fppi_matrices(*self._block_parameters()))

    def packed_block(self) -> tuple[np.ndarray, int, int]:
        """:func:`packed_block` of :meth:`block`."""
        return _packed_fppi(*self._block_parameters())

    def _block_parameters(self) -> tuple[float, float, float, float, float]:
        return self.proportional_gain, self.gain, self.time_constant, self.tf, self.dead_time

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": "fppi",
            "model": {"gain": self.gain, "time_constant": self.time_constant, "dead_time": self.dead_time},
            "tr": self.tr,
            "tf": self.tf,
        }


@dataclass(frozen=True)
class MSP:
    """Modified Smith predictor for integrating plants (Ingimundarson section 5, Fig. 10).

    ``e_d = y - G_n e^{-L_n s} u_r``, ``u_r = K_r (r - G_n u_r - e_d)``, ``u = u_r - F e_d`` with
    ``G_n = K_n/s``, ``K_r = 1/(K_n T_r)`` (eq. 38) and ``F = K_0 = 1/(2 L_n K_n)`` (eq. 36), or
    with ``extension=True`` the PD-type ``F = K_0 (T_d s + 1)/(T_d s/10 + 1)``, ``T_d = 0.4 L_n``,
    ``K_0 = 0.6/(L_n K_n)`` (eq. 51).  With a perfect model the set-point response is
    ``e^{-L_n s}/(T_r s + 1)`` (eq. 37) and the loop with a dead-time error is eq. 47.
    """

    gain: float
    dead_time: float
    tr: float
    extension: bool = False

    def __post_init__(self) -> None:
        require_number(self.gain, "model.gain", nonzero=True)
        require_number(self.dead_time, "model.dead_time", positive=True)
        require_number(self.tr, "tr", positive=True)
        if not isinstance(self.extension, bool):
            raise ValueError(f"extension must be true or false, got {self.extension!r}")

    integrators = 1

    @property
    def k0(self) -> float:
        return (0.6 if self.extension else 0.5) / (self.dead_time * self.gain)

    @property
    def kr(self) -> float:
        return 1.0 / (self.gain * self.tr)

    @property
    def derivative_time(self) -> float:
        return 0.4 * self.dead_time

    def _parts(self, omega: np.ndarray):
        s = 1j * np.asarray(omega, dtype=float)
        f = self.k0 * np.ones_like(s)
        if self.extension:
            td = self.derivative_time
            f = self.k0 * (td * s + 1) / (td * s / 10 + 1)
        model = self.gain / s * np.exp(-s * self.dead_time)
        # K_r/(1 + K_r G_n (1 - e^{-L_n s})) = (1/K_n) s/(T_r s + 1 - e^{-L_n s})
        smith = s / (self.gain * (self.tr * s + 1 - np.exp(-s * self.dead_time)))
        return f, model, smith

    def feedback_response(self, omega: np.ndarray) -> np.ndarray:
        """``F + K_r (1 + F P_n)/(1 + K_r G_n (1 - e^{-L_n s}))``."""
        f, model, smith = self._parts(omega)
        return f + smith * (1 + f * model)

    def reference_response(self, omega: np.ndarray) -> np.ndarray:
        """``K_r (1 + F P_n)/(1 + K_r G_n (1 - e^{-L_n s}))``."""
        f, model, smith = self._parts(omega)
        return smith * (1 + f * model)

    def block(self) -> DelaySystem:
        """``u = u_r - F e_d``, ``u_r = K_r (r - m - e_d)``, ``e_d = y - m(t - L_n)``, with the model
        output ``m' = K_n u_r`` and, with the extension, the lead state of ``F``: the rows of these
        equations, filled in by one compiled call (:func:`~envs.systems._controllers_kernels._msp_matrices`)."""
        return DelaySystem(*_msp_matrices(*self._block_parameters()))

    def packed_block(self) -> tuple[np.ndarray, int, int]:
        """:func:`packed_block` of :meth:`block`."""
        return _packed_msp(*self._block_parameters())

    def _block_parameters(self) -> tuple[float, float, float, float, float, bool]:
        lead = self.derivative_time / 10 if self.extension else 1.0
        return self.kr, self.k0, self.gain, lead, self.dead_time, self.extension

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": "msp",
            "model": {"gain": self.gain, "dead_time": self.dead_time},
            "tr": self.tr,
            "extension": self.extension,
        }


Controller = PID | SeriesPID | FPPI | MSP


def packed_block(controller: Controller) -> tuple[np.ndarray, int, int]:
    """``controller.block()`` as one flat array for compiled code: the ten matrices ``A, B1, B2,
    C1, D11, D12, C2, D21, D22, delays`` raveled and concatenated in this order, with the numbers
    of states and of delays (which give every shape: two inputs ``[r, y]``, one output ``u``).

    The same numbers as :meth:`block` (the same kernel, copied into place): a compiled call that
    returns one array instead of ten, each of which Python would box at about a microsecond.
    """
    return controller.packed_block()

_FIELDS = {
    "pid": ({"kp", "ti"}, {"td", "n"}),
    "pid-series": ({"kp", "ti"}, {"td", "n"}),
    "fppi": ({"model", "tr"}, {"tf"}),
    "msp": ({"model", "tr"}, {"extension"}),
}
_MODEL_FIELDS = {"fppi": {"gain", "time_constant", "dead_time"}, "msp": {"gain", "dead_time"}}


def controller_from_dict(data: Any) -> Controller:
    """Parse the controller JSON of ``deadtime analyze`` (docs/command_line.md); errors name the field."""
    if not isinstance(data, dict):
        raise ValueError(f"controller must be a JSON object, got {type(data).__name__}")
    kind = data.get("type")
    if not isinstance(kind, str) or kind not in _FIELDS:
        raise ValueError(f"controller.type must be one of {sorted(_FIELDS)}, got {kind!r}")
    required, optional = _FIELDS[kind]
    check_keys(set(data) - {"type"}, "controller", required, optional, kind)
    fields = {k: v for k, v in data.items() if k != "type"}
    try:
        if kind in ("pid", "pid-series"):
            cls = PID if kind == "pid" else SeriesPID
            return cls(**fields)
        model = fields.pop("model")
        if not isinstance(model, dict):
            raise ValueError(f"model must be an object with keys {sorted(_MODEL_FIELDS[kind])}")
        check_keys(model, "model", _MODEL_FIELDS[kind])
        cls = FPPI if kind == "fppi" else MSP
        return cls(**model, **fields)
    except ValueError as error:
        raise ValueError(f"controller.{error}") from None


