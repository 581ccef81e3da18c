"""``python -m stability {verify,stability,plot-growth}``."""

import sys

from icidr_pde.cli.stability import main

sys.exit(main())
