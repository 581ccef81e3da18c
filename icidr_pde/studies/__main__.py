"""``python -m icidr_pde.studies ...``: the same as ``icidr-pde tstar ...``."""

import sys

from .cli import main

sys.exit(main())
