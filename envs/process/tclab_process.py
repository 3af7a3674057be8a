"""The Temperature Control Lab (``tclab`` 1.0.0, BYU) as a :class:`~envs.process.protocol.Process`.

The TCLab is an Arduino shield with two heaters and two temperature sensors, thermally coupled; its
Python package ships the emulator ``tclab.TCLabModel`` beside the USB class ``tclab.TCLab``, with
the same interface (``T1``, ``T2``, ``Q1(value)``, ``Q2(value)``, ``close()``).  The loop here is
heater 1 (``Q1``, 0-100 %) to sensor 1 (``T1``, degC), with heater 2 (``Q2``) as the load.

The emulator (``tclab/tclab.py``), which nobody here wrote, integrates by Euler steps of at most
0.2 s the heater temperatures ``H1``, ``H2`` (lags of about 20 s, coupled) and the sensor lags
(140 s), from the ambient 21 degC; its nonlinear parts are the heater saturation at 0 and 100 %
and the sensor: noise ``N(0, 0.043)`` from Python's global ``random``, then quantization to
0.3223 degC (floor, as the Arduino's A/D converter).  It has no true dead time: the apparent one
comes from the lags in series.  Its static gain is about 0.6 degC/% (heater 1) and 0.05 degC/%
(heater 2, through the coupling), ``T_ar`` about 160 s.

What this adapter does around ``TCLabModel(synced=False)``:

* the emulator's clock is driven by ``update(t)`` once per sample (``synced=False``: about 10^5
  times faster than real time); the model's clock starts at 0 at each :meth:`TCLabProcess.reset`
  (``TCLabModel`` starts it at the reading of ``tclab.labtime``, which with ``synced=False`` only
  shifts every time by an arbitrary offset);
* its noise is seeded: the emulator draws it with ``random.normalvariate`` from the module
  ``random`` it imported (``tclab.tclab.random``, Python's global generator); while this adapter
  reads ``T1``, that name is bound to the adapter's own ``random.Random(seed)`` and rebound to the
  module right after.  The same seed gives the same measurements bit for bit (those of
  ``random.seed(seed)`` and the emulator used directly), and Python's global generator is neither
  drawn from nor reseeded: nothing else in the process sees a difference.  (Swapping the global
  generator's state in and out around each read, ``random.getstate``/``setstate``, did the same at
  35 us per sample, seven times the emulator's own cost.);
* its prints (``TCLab version ...``, ``Simulated TCLab``, ``TCLab Model disconnected ...``) are kept
  off the terminal.

Real hardware is the same class interface (``tclab.TCLab()`` over USB: ``T1``, ``Q1``, ``Q2``,
``close``), in real time: an adapter for it is this class with ``reset`` turning the heaters off
and waiting for the kit to cool (it cannot return to ambient otherwise, and the seed does nothing)
and ``apply`` waiting one sample time of real time (``time.sleep``, or ``tclab.clock``) instead of
calling ``update(t)``.  It is a few lines (docs/real_process.md shows them); it is not included because
nothing here can test it.
"""

from __future__ import annotations

import contextlib
import io
import random
import sys
from collections.abc import Callable
from typing import Any

from envs.process.protocol import Units
from envs.validation import require_number

__all__ = ["TCLAB_QUANTIZATION", "TCLabProcess"]

TCLAB_QUANTIZATION = 0.3223
"""The step of the kit's temperature readings, degC (``tclab.TCLabModel.quantize``)."""


class TCLabProcess:
    """Heater 1 to sensor 1 of the TCLab emulator, heater 2 as the load (see the module docstring).

    Parameters
    ----------
    sample_time : float
        Seconds per sample; default 1 s, the kit's.
    operating_input : float
        Heater 1 at the operating point, % (default 30 %: about 39 degC).
    setpoint_step : float
        degC (default 10: the output moves well beyond the 0.32 degC quantization).
    input_step : float
        % of heater 1 for the first open-loop step (default 10 %).
    load_step : float
        % of heater 2 in the load test (default 100 %: about +5 degC on T1 in open loop).
    settling_time : float
        s (default 900 s: the open-loop response to a step settles in about 10 minutes).
    lab_factory : callable, optional
        Makes the emulator; default ``tclab.TCLabModel(synced=False)``.  Anything with its interface
        (``T1``, ``Q1``, ``Q2``, ``update(t)``, ``tlast``, ``close``), e.g. a subclass with other
        heater powers.
    quantization : float, optional
        The sensor's resolution, degC: default the ``quantization`` attribute of ``lab_factory`` (the
        emulators of :func:`~envs.process.tclab_conditions.emulator_factory` have it), else the kit's
        0.3223 degC.  The observation's noise estimate reads the records with it.
    """

    name = "tclab"
    input_limits = (0.0, 100.0)
    load_limits = (0.0, 100.0)
    """Heater 2, % (the emulator clips it): the load test's step must lie in it."""
    load_gain = 100.0 / 5720.0 / 0.35
    """degC per % of heater 2 at steady state, from the emulator's equations: ``P2/5720`` degC/s per %
    into ``H2``, losses ``1/20`` to ambient and ``1/100`` between the heaters, so ``H1 = H2/6`` and
    ``H2 (1/20 + 1/100 - 1/600) = P2 Q2/5720``: 0.0500 (heater 1 likewise: ``P1/5720/0.058333`` = 0.599)."""
    units = Units(time="s", input="% heater 1", output="degC", load="% heater 2")

    def __init__(
        self,
        *,
        sample_time: float = 1.0,
        operating_input: float = 30.0,
        setpoint_step: float = 10.0,
        input_step: float = 10.0,
        load_step: float = 100.0,
        settling_time: float = 900.0,
        lab_factory: Callable[[], Any] | None = None,
        quantization: float | None = None,
    ) -> None:
        self.sample_time = require_number(sample_time, "sample_time", positive=True)
        self.operating_input = require_number(operating_input, "operating_input")
        self.setpoint_step = require_number(setpoint_step, "setpoint_step", nonzero=True)
        self.input_step = require_number(input_step, "input_step", nonzero=True)
        self.load_step = require_number(load_step, "load_step", nonzero=True)
        self.settling_time = require_number(settling_time, "settling_time", positive=True)
        self._factory = lab_factory if lab_factory is not None else _emulator
        if quantization is None:
            quantization = getattr(lab_factory, "quantization", TCLAB_QUANTIZATION)
        self.quantization = require_number(quantization, "quantization", nonnegative=True)
        self._lab: Any = None
        self._random = random.Random(0)
        self._samples = 0

    def reset(self, seed: int) -> None:
        """A new emulator at ambient temperature, its clock at 0, its noise seeded by ``seed``."""
        self.close()
        self._random = random.Random(int(seed))
        self._lab = _quietly(self._factory)
        self._lab.tlast = 0.0  # the emulator's own clock from 0 (see the module docstring)
        self._samples = 0

    def _started(self) -> Any:
        if self._lab is None:
            self.reset(0)
        return self._lab

    def measure(self) -> float:
        """``T1`` in degC (quantized, noisy), at the present sample, the noise from this process's
        own generator (see the module docstring)."""
        lab = self._started()
        measurement = getattr(type(lab), "measurement", None)  # the module of the code that draws the noise
        module = sys.modules.get(getattr(measurement, "__module__", ""), None)
        drawn_from = getattr(module, "random", None)
        if drawn_from is not random:  # not the emulator of tclab 1.0.0: read it as it is
            return float(lab.T1)
        module.random = self._random
        try:
            return float(lab.T1)
        finally:
            module.random = random

    def apply(self, control: float, load: float = 0.0) -> None:
        """``Q1 = control`` and ``Q2 = load`` (the emulator clips both to 0-100 %), for one sample."""
        lab = self._started()
        lab.Q1(control)
        lab.Q2(load)
        self._samples += 1
        lab.update(self._samples * self.sample_time)

    def close(self) -> None:
        """Turn the heaters off and close the lab (its print kept off the terminal)."""
        if self._lab is not None:
            lab, self._lab = self._lab, None
            _quietly(lab.close)


def _quietly(call: Callable[[], Any]) -> Any:
    """``call()`` with its prints kept off the terminal."""
    with contextlib.redirect_stdout(io.StringIO()):
        return call()


def _emulator() -> Any:
    import tclab

    return tclab.TCLabModel(synced=False)
