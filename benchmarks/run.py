#!/usr/bin/env python3
"""Benchmark suite: records its table on docs/benchmarks.md (benchmarks/report.py) and writes docs/runtime_vs_error.png (see bench.py)."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
