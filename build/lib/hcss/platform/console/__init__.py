"""The experimenter console: accounts, participants, live progress, withdrawal, export.

Nothing outside the console imports it (docs/architecture.md).
"""
