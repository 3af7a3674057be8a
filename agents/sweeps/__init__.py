"""Many seeds and configs on Ray Tune (``deadtime sweep``): the command (:mod:`.sweep`), the sweep
file's schema (:mod:`.config`), where it runs (:mod:`.cluster`), the trials (:mod:`.run`, with their
callback in :mod:`.reporter`), what a resume checks first (:mod:`.resume`), Ctrl-C (:mod:`.interrupts`)
and the summary over seeds (:mod:`.summary`).
"""
