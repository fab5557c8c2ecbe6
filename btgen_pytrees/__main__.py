"""``python -m btgen_pytrees``: see :mod:`btgen_pytrees.cli`."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
