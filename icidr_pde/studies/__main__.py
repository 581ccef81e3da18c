"""``python -m icidr_pde.studies ...``: the same as ``icidr-pde tstar ...``."""

import sys

from icidr_pde.cli import main

argv = sys.argv[1:]
sys.exit(main(argv if argv[:1] == ["tstar"] else ["tstar"] + argv))
