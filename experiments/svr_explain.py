"""Why the rows of Table 1 differ (the DoFs each rule holds, the importances rho cuts):
`python experiments/svr_explain.py --quick`; --help says more. The experiment is
planners.svr_mpc.experiments.explain."""
# parser and summarize_rows: resummarize.py reads them through this script until it moves
from planners.svr_mpc.experiments.explain import main, parser, summarize_rows  # noqa: F401

if __name__ == "__main__":
    raise SystemExit(main())
