"""Pictures of patterns (SVG/PNG), the catalog's scatter plots and the browsing page (paper §4.2)."""
