"""Processes: the same experiments, rules and agents on any sampled process.

A process is anything with the interface of :class:`~envs.process.protocol.Process` (a sample time,
input limits, an operating point, a seed; ``measure()`` and ``apply(u, load)``): the project's own
plants (:class:`~envs.process.plant_process.PlantProcess`), the TCLab emulator
(:class:`~envs.process.tclab_process.TCLabProcess`), a user's simulator or hardware.  On it:

* :mod:`envs.process.runs`: holding an input, a discrete loop, a relay, sample by sample;
* :mod:`envs.process.control_laws`: the designed controllers (PID, series PID, FPPI) as discrete laws
  with anti-windup and a filtered derivative (Marlin ch. 11-12);
* :mod:`envs.process.procedure`: the operating point, the commissioning controller and the fixed
  procedure's experiments, identified with the simulated experiments' own arithmetic;
* :mod:`envs.process.performance`: a controller's set-point and load tests on the process itself;
* :mod:`envs.process.scoring`: their cost, with the robustness of the loop on the identified model.

No module here imports gymnasium or torch.
"""
