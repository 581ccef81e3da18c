"""``python -m icidr_pde.cli``: the ``icidr-pde`` command."""

import sys

from . import main

sys.exit(main())
