"""Operating conditions of the TCLab emulator: ambient temperature, heater power, sensor noise and quantization.

The emulator (``tclab.TCLabModel``) fixes them: 21 degC ambient, heater 1 at 200 (heater power
``P1``, in the units of its equations: ``dH1/dt = P1 Q1/5720 + ...``), a sensor noise of 0.043 degC
quantized to 0.3223 degC.  A :class:`TCLabConditions` changes them, and :func:`emulator_factory` makes
the emulators of :class:`~envs.process.tclab_process.TCLabProcess` under them (its ``lab_factory``):
the model starts at rest at the ambient temperature, heater 1's power scales the process gain
(``P1/5720/0.0583`` degC per %: 0.599 at 200), and the measurement is ``quantize(T + N(0, noise_std))``
with the quantizer's floor of step ``quantization`` (none at 0).  ``disturbance`` (% of heater 2) is
an unmeasured load that steps on ``disturbance_time`` seconds after each reset and stays, on top of
what the process applies to heater 2: it hits the identification's experiments and every test alike.  The noise is drawn from the module
global ``random``, which :class:`~envs.process.tclab_process.TCLabProcess` binds to its own seeded
generator while it reads, as for the emulator itself: the same seed gives the same run.

:data:`CONDITIONS` are the transfer study's: the emulator as shipped, a cold and a warm room, heater 1
at three quarters and at one and a half of its power, a sensor four times noisier, one without the
quantizer, and heater 2 stepping to 20% 2000 s after each reset (during the identification's experiments).
"""

from __future__ import annotations

import random
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from envs.validation import require_number

__all__ = ["CONDITIONS", "TCLabConditions", "emulator_factory"]


@dataclass(frozen=True)
class TCLabConditions:
    """One condition of the emulator (module docstring); the defaults are the emulator's own."""

    name: str = "nominal"
    ambient: float = 21.0
    heater_power: float = 200.0
    noise_std: float = 0.043
    quantization: float = 0.3223
    disturbance: float = 0.0
    disturbance_time: float = 2000.0

    def __post_init__(self) -> None:
        require_number(self.ambient, "ambient")
        require_number(self.heater_power, "heater_power", positive=True)
        require_number(self.noise_std, "noise_std", nonnegative=True)
        require_number(self.quantization, "quantization", nonnegative=True)
        require_number(self.disturbance, "disturbance", nonnegative=True)
        require_number(self.disturbance_time, "disturbance_time", nonnegative=True)


CONDITIONS: tuple[TCLabConditions, ...] = (
    TCLabConditions("nominal"),
    TCLabConditions("cold room", ambient=12.0),
    TCLabConditions("warm room", ambient=30.0),
    TCLabConditions("heater at 75%", heater_power=150.0),
    TCLabConditions("heater at 150%", heater_power=300.0),
    TCLabConditions("noisy sensor", noise_std=0.172),
    TCLabConditions("no quantization", quantization=0.0),
    TCLabConditions("load disturbance", disturbance=20.0),
)
"""The transfer study's conditions."""


def emulator_factory(conditions: TCLabConditions) -> Callable[[], Any]:
    """A ``lab_factory`` for :class:`~envs.process.tclab_process.TCLabProcess` under ``conditions``."""
    import tclab

    class ConditionedModel(tclab.TCLabModel):
        def __init__(self) -> None:
            super().__init__(synced=False)
            self.Ta = self._T1 = self._T2 = self._H1 = self._H2 = float(conditions.ambient)
            self._P1 = float(conditions.heater_power)

        def Q2(self, val: float | None = None) -> float:
            if val is not None and conditions.disturbance and self.tlast >= conditions.disturbance_time:
                val = val + conditions.disturbance
            return super().Q2(val)

        def measurement(self, T: float) -> float:
            value = T + random.normalvariate(0, conditions.noise_std)
            step = conditions.quantization  # the emulator's quantize(), of this step
            return value if step == 0 else max(-50, min(132.2, value - value % step))

    ConditionedModel.quantization = float(conditions.quantization)  # the sensor's resolution, for TCLabProcess
    return ConditionedModel
