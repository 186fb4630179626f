"""``python -m bkflow.cli``: the ``bkflow`` command, for an environment without its script."""

import sys

from bkflow.cli import main

sys.exit(main())
