"""``python -m pipeline.targets``: the front door (``cli.main``)."""

import sys

from .cli import main

sys.exit(main())
