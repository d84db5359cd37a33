"""`make bench`: performance figures, printed (python -m benchmarks)."""
