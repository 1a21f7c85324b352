"""fabpat: fabricable geometric patterns for flat mechanical metamaterials."""

__version__ = "0.1.0"
