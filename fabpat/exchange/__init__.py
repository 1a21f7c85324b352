"""File formats: one module per format (STEP, STL, 3MF, DXF, SVG, …), each a writer over fabpat geometry."""
