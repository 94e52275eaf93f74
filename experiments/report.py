"""Generate docs/RESULTS.md, the papers' pages and README's map from the result files:
`python experiments/report.py [--check]`; --help says more (``dopt.lab.report``)."""

import sys

from dopt.lab.report.cli import main

if __name__ == "__main__":
    sys.exit(main())
