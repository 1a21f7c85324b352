"""Slices, patterns and the library of connected tileable ones (paper §3.1–3.2), their metrics and
continuous variations."""
