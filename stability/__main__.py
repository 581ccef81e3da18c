"""``python -m stability {verify,stability,plot-growth}``."""

import sys

from .cli import main

sys.exit(main())
