"""Many seeds and configs on Ray Tune (``deadtime sweep``): the command (:mod:`.sweep`), the sweep
file's schema (:mod:`.config`), the trials (:mod:`.run`, with their callback in :mod:`.reporter`) and
the summary over seeds (:mod:`.summary`).
"""
