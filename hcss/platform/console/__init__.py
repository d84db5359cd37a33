"""The experimenter console: accounts, participants, live progress, withdrawal, export.

Kept import-light on purpose: the live runner imports `console.pauses`, and
must not pull in the console's views to do so.
"""
