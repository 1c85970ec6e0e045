"""``python -m mbimpact`` is the ``mbimpact`` command."""

import sys

from .cli import main

sys.exit(main())
