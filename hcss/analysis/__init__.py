"""hcss.analysis."""
