#!/usr/bin/env python3
"""Benchmark suite: writes docs/benchmarks.md and docs/runtime_vs_error.png (see kinbox.bench)."""
import sys

from kinbox.bench import main

if __name__ == "__main__":
    sys.exit(main())
