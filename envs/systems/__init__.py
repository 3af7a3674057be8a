"""The systems: plants ``G(s) e^{-Ls}`` (:mod:`.plants`; their coefficients :mod:`.coefficients`, their
state-space realization :mod:`.state_space`), the random plant families and the papers'
benchmark batches (:mod:`.families`), the fixed validation and test sets (:mod:`.plant_sets`), and the
controllers (PID forms, FPPI, modified Smith predictor) as blocks (:mod:`.controllers`).
"""
