"""The project's own plants as a sampled :class:`~envs.process.protocol.Process`.

:class:`PlantProcess` samples a :class:`~envs.systems.plants.Plant` ``G(s) e^{-Ls}`` with the exact
simulation of :mod:`envs.simulation.delay_systems`: the zero-order-hold map of
:func:`~envs.simulation.discretization.delayed_zoh` (the dead time split into whole samples and an
exact fractional part, no Pade approximation), advanced one sample per :meth:`PlantProcess.apply`
for whatever input the caller holds.  So the process path (a discrete controller on sampled data)
and the LTI path (``deadtime analyze``) can be compared where both apply: they differ only by the
sampling of the controller.

The load enters at the plant input (``u + load``), as the load of ``deadtime analyze``.  The plant
starts at rest at its operating point (``y_0 = K u_0``, the state in steady state; an integrating
plant only at ``u_0 = 0``); the measurement is ``y + n`` with white Gaussian noise ``n`` of
``noise_std`` per sample, drawn from ``numpy.random.default_rng(seed)`` at each :meth:`reset`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from envs.process.protocol import Units
from envs.simulation.discretization import delayed_zoh
from envs.systems.plants import as_plant
from envs.validation import require_number

__all__ = ["PlantProcess", "PlantProcessOptions", "SAMPLES_PER_RESIDENCE_TIME"]

SAMPLES_PER_RESIDENCE_TIME = 200
"""Default samples per ``T_ar`` of the plant (``T_ar/200``, the experiments' default sampling)."""


@dataclass(frozen=True)
class PlantProcessOptions:
    """How :class:`PlantProcess` runs its plant; the keyword arguments of ``PlantProcess`` fill it.

    Attributes
    ----------
    sample_time : float, optional
        Default ``T_ar/SAMPLES_PER_RESIDENCE_TIME`` (``T_ar`` of the plant).
    input_limits : (float, float)
        Default none (``(-inf, inf)``).
    operating_input : float
        ``u_0``; 0 for an integrating plant.
    noise_std : float
        Measurement noise per sample.
    setpoint_step, input_step, load_step : float, optional
        Defaults: a unit rise of the output (1), the input step of a unit rise (``1/K``), a unit
        load at the plant input (1): the amplitudes of the environments.
    settling_time : float, optional
        Default ``10 T_ar``.
    name : str
        The process's name in reports.  Default ``"plant"``.
    """

    sample_time: float | None = None
    input_limits: tuple[float, float] = (-math.inf, math.inf)
    operating_input: float = 0.0
    noise_std: float = 0.0
    setpoint_step: float = 1.0
    input_step: float | None = None
    load_step: float = 1.0
    settling_time: float | None = None
    name: str = "plant"


class PlantProcess:
    """A :class:`~envs.systems.plants.Plant` as a process (see the module docstring).

    Parameters
    ----------
    plant : Plant, dict or any form :func:`~envs.systems.plants.as_plant` takes
    options : PlantProcessOptions, optional
        Default ``PlantProcessOptions()``.
    **overrides
        Fields of :class:`PlantProcessOptions` to set, e.g. ``PlantProcess(plant, noise_std=0.1)``.
    """

    def __init__(self, plant: object, options: PlantProcessOptions | None = None, **overrides: object) -> None:
        self.plant = as_plant(plant)
        self._configure(dataclasses.replace(options or PlantProcessOptions(), **overrides))
        self.units = Units(time="", input="", output="", load="")
        ss = self.plant.state_space()
        self._phi, gamma0, gamma1, self._whole = delayed_zoh(ss, self.plant.dead_time, self.sample_time)
        self._gamma0, self._gamma1 = gamma0.ravel(), gamma1.ravel()
        self._fractional = bool(np.any(self._gamma1))
        self._c, self._d = np.asarray(ss.C, dtype=float).ravel(), float(ss.D.ravel()[0]) if ss.D.size else 0.0
        self._steady = self._steady_state(ss)
        self.reset(0)

    def _configure(self, options: PlantProcessOptions) -> None:
        """The options checked, each one a named attribute of the process (its interface)."""
        scale = self.plant.step_time_scale()
        self.sample_time = scale / SAMPLES_PER_RESIDENCE_TIME if options.sample_time is None else require_number(
            options.sample_time, "sample_time", positive=True)
        self.input_limits = (float(options.input_limits[0]), float(options.input_limits[1]))
        self.operating_input = require_number(options.operating_input, "operating_input")
        if self.plant.integrating and self.operating_input != 0.0:
            raise ValueError("operating_input must be 0 for an integrating plant (no other input is at rest), "
                             f"got {options.operating_input!r}")
        self.noise_std = require_number(options.noise_std, "noise_std", nonnegative=True)
        self.setpoint_step = require_number(options.setpoint_step, "setpoint_step", nonzero=True)
        self.input_step = (1.0 / self.plant.gain if options.input_step is None
                           else require_number(options.input_step, "input_step", nonzero=True))
        self.load_step = require_number(options.load_step, "load_step", nonzero=True)
        self.load_gain = None  # the load enters at the plant input
        self.settling_time = (10.0 * scale if options.settling_time is None
                              else require_number(options.settling_time, "settling_time", positive=True))
        self.name = options.name

    def _steady_state(self, ss) -> np.ndarray:
        """The state at rest for the operating input: ``x = -A^{-1} B u_0`` (0 if ``u_0 = 0``)."""
        n = ss.A.shape[0]
        if self.operating_input == 0.0 or n == 0:
            return np.zeros(n)
        return -np.linalg.solve(ss.A, ss.B[:, 0] * self.operating_input)

    def reset(self, seed: int) -> None:
        """At rest at the operating point, sample 0, the noise drawn from ``default_rng(seed)``."""
        self._rng = np.random.default_rng(seed)
        self._x = self._steady.copy()
        self._inputs: list[float] = []  # the plant inputs u + load applied so far, one per sample
        self._noise: tuple[int, float] | None = None

    def _input(self, index: int) -> float:
        """The plant input held over sample ``index`` (the operating input before the start)."""
        return self._inputs[index] if index >= 0 else self.operating_input

    def measure(self) -> float:
        """``y(k dt) + n_k``: ``C x_k + D u(k dt - L)``, the delayed input taken just before sample
        ``k``'s own input is applied when the dead time is zero (a biproper plant without dead time)."""
        k = len(self._inputs)
        delayed = k - self._whole - (1 if self._fractional else 0)
        y = float(self._c @ self._x) + self._d * self._input(min(delayed, k - 1))
        if self._noise is None or self._noise[0] != k:
            self._noise = (k, self.noise_std * float(self._rng.standard_normal()) if self.noise_std > 0 else 0.0)
        return y + self._noise[1]

    def apply(self, control: float, load: float = 0.0) -> None:
        """Hold ``clip(control) + load`` at the plant input for one sample: ``x <- Phi x + Gamma0
        u[k - m] + Gamma1 u[k - m - 1]`` (:func:`~envs.simulation.discretization.delayed_zoh`)."""
        low, high = self.input_limits
        self._inputs.append(min(max(float(control), low), high) + float(load))
        k = len(self._inputs) - 1
        forced = self._gamma0 * self._input(k - self._whole)
        if self._fractional:
            forced = forced + self._gamma1 * self._input(k - self._whole - 1)
        self._x = self._phi @ self._x + forced

    def close(self) -> None:
        """Nothing to release."""
