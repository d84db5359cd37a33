"""The study export: tidy tables per docs/data-dictionary.md, as CSV (and Parquet)."""
