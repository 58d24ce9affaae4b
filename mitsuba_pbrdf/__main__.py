"""``python -m mitsuba_pbrdf ...``: the ``pbrdf`` command line."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
