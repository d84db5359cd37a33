"""The experiments on the model: batches, sweeps, calibration, fidelity, mean-field and
the equivalence check, and the `hcss simulate` commands that run them.

They drive `hcss.simulation` from outside and may ask `hcss.analysis` for a
summary; the model imports nothing from here.
"""
