"""Live trials: the runner that steps them, their stream, commands and probes."""
