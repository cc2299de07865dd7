"""``python -m spatialmbd``: the same as the ``spatialmbd`` command (see spatialmbd.cli)."""
import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
