"""Replay of a recorded trial in the Collective Interface, for the experimenter's console."""
