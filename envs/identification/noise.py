"""White measurement noise of one experiment, drawn as the run needs it.

:func:`envs.identification.experiment_base.measurement_noise` makes one per experiment, from a child
stream of the episode's generator (the conventions are in :mod:`envs.identification.experiment_base`);
:class:`envs.identification.disturbances.DisturbedNoise` adds a drift and a load to it.

The sensor may also have a finite resolution (``quantization``, the step ``q`` of its readings, in
output units): :func:`sensor_reading` floors a measurement to a multiple of ``q``, ``y - (y mod q)``,
exactly the quantizer of the TCLab (``tclab.TCLabModel.quantize``: ``T - T % 0.3223``, the Arduino's
A/D converter), without its clip to [-50, 132.2] degC (the outputs here are deviations in relative
units).  At ``q = 0`` a reading is the measurement itself, untouched.
"""

from __future__ import annotations

import numpy as np

__all__ = ["MeasurementNoise", "sensor_reading"]


def sensor_reading(measured, quantization: float):
    """``measured`` (a float or an array) as the sensor reads it: floored to a multiple of
    ``quantization`` (``measured - measured % quantization``, the TCLab's quantizer), or ``measured``
    itself, the same object, at ``quantization == 0``."""
    if quantization == 0.0:
        return measured
    return measured - measured % quantization


class MeasurementNoise:
    """White Gaussian noise ``noise_std * z`` of the samples of one experiment, drawn as needed.

    ``first(count)`` is the noise of samples ``0 .. count - 1``: the standard normals ``z`` of the
    child stream ``source`` in order, drawn up to the largest ``count`` asked so far (none at all when
    ``noise_std`` is 0).  ``size`` is the cap, the number of samples of the longest run allowed.
    ``quantization`` is the sensor's resolution the experiment applies to its measurements
    (:func:`sensor_reading`; 0: none).
    """

    quantization: float = 0.0

    def __init__(self, noise_std: float, size: int, source: np.random.Generator | None) -> None:
        self.noise_std, self.size, self._source = noise_std, int(size), source
        self._values = np.empty(0)  # the samples, drawn into this buffer of ``size`` when first needed
        self._drawn = 0

    @classmethod
    def given(cls, values: np.ndarray) -> MeasurementNoise:
        """Noise with the given samples (e.g. to replay a run)."""
        noise = cls(0.0, np.size(values), None)
        noise._values = np.asarray(values, dtype=float).ravel()
        noise._drawn = noise.size
        return noise

    @property
    def drawn_as_needed(self) -> bool:
        """Whether samples are drawn from the child stream when first asked for (not given or zero)."""
        return self._source is not None and self.noise_std != 0.0 and self._drawn < self.size

    def first(self, count: int) -> np.ndarray:
        count = min(int(count), self.size)
        drawn = self._drawn
        if count > drawn:
            if self._values.size < self.size:
                self._values = np.empty(self.size)
            self._fill(self._values[drawn:count], drawn, count)
            self._drawn = count
        return self._values[:count]

    def _fill(self, fresh: np.ndarray, drawn: int, count: int) -> None:
        """Write samples ``drawn .. count - 1`` into ``fresh`` (the buffer's slice for them)."""
        if self.noise_std == 0.0 or self._source is None:
            fresh[:] = 0.0
        else:  # the normals of standard_normal(count - drawn), scaled in place: the same products
            self._source.standard_normal(out=fresh)
            fresh *= self.noise_std
