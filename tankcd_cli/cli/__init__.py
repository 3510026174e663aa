"""Command layer: one module per command; no numpy at import time."""
