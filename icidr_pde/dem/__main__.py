"""``python -m icidr_pde.dem steady|transient ...``"""

import sys

from ..cli.dem import main

if __name__ == "__main__":
    sys.exit(main())
