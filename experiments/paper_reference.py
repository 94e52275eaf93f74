"""The state-vector-reduction authors' run summaries and published Table 1 as a result file:
`python experiments/paper_reference.py --tsv FILE --record docs/results/paper-svr.json`;
--help says more. The command is planners.svr_mpc.experiments.paper_reference."""
from planners.svr_mpc.experiments.paper_reference import main

if __name__ == "__main__":
    raise SystemExit(main())
