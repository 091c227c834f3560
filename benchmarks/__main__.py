"""``python -m benchmarks``: run the benchmark suite (see :mod:`benchmarks.command`)."""

import sys

from benchmarks.command import main

sys.exit(main())
