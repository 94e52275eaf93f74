"""Rebuild the summaries under docs/results from their committed trials and compare:
`python experiments/resummarize.py [--check | --out DIR | --in-place]`; --help says more
(``dopt.lab.report.resummarize``)."""

import sys

from dopt.lab.report.resummarize import main

if __name__ == "__main__":
    sys.exit(main())
