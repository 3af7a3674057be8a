"""The systems: plants ``G(s) e^{-Ls}`` (:mod:`.plants`), the random plant families and the papers'
benchmark batches (:mod:`.families`), the fixed validation and test sets (:mod:`.plant_sets`), and the
controllers (PID forms, FPPI, modified Smith predictor) as blocks (:mod:`.controllers`).
"""
