"""Speed and accuracy (``deadtime bench``): the command (:mod:`.bench`), our scoring against the
python-control way (:mod:`.scoring`, :mod:`.reference`) and a fine-step reference
(:mod:`.fine_step`), and the environments' episodes per second and share of training
(:mod:`.episodes`).
"""
