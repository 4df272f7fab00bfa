"""``python -m navigation``: the same as the ``objrec-patrol`` command."""

import sys

from .cli import main

sys.exit(main())
