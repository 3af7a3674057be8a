"""The analytic tuning rules: the registry of every rule by name (:mod:`.registry`), the PI/PID rules
(:mod:`.pid` formulas, :mod:`.pid_forms`, :mod:`.pid_registry`), the Gorez-Klan ``mu`` rules
(:mod:`.mu`), the ``T_r`` rules of the dead-time compensators (:mod:`.dtc`) and ``deadtime tune``
(:mod:`.tune`).
"""
