"""``python -m quadsim``: the same as the ``quadsim`` command."""

from quadsim.cli import main

raise SystemExit(main())
