"""hcss: human-collective site selection, from consent form to statistical table."""

__version__ = "0.1.0"
