"""Regenerate the bundled sample data (deterministic): python sample_data/make_sample_data.py [OUT_DIR]."""

import sys
from pathlib import Path

from tankcd_cli.sample import write_sample

if __name__ == "__main__":
    write_sample(sys.argv[1] if len(sys.argv) > 1 else str(Path(__file__).resolve().parent))
