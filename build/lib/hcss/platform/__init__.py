"""hcss.platform."""
