"""hcss.simulation."""
