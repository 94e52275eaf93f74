"""``python -m dopt.view PATH``: the same as ``dopt-view PATH`` (``dopt.view.cli``)."""

import sys

from dopt.view.cli import main

sys.exit(main())
