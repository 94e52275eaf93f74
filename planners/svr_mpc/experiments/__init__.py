"""The state-vector-reduction paper's experiments: one object per figure or table (its flags,
settings, trials, summary and report section), registered once for the report
(``dopt.lab.experiment``); ``experiments/`` keeps a thin command line over each, whose
``main(argv=None) -> int`` lives here.

    table1.py    Table 1 (experiments/mpc.py, dopt-mpc): rows x seeds of MPC episodes
    fig4.py      Fig. 4 (experiments/rho_sweep.py): cost and |C| against rho, per theta
    explain.py   why the rows differ (experiments/svr_explain.py): sets and importances
    clock_check.py  the virtual clock against the real one on the same trials
    paper_reference.py  the authors' run summaries and printed Table 1 as a result file
    flags.py     the flags the MPC experiments share, and their checks as usage errors
    mapping.py   the flags as SVRMPCSettings and keyed trials; the protocol a summary records
    runner.py    the sweep of MPC trials with its console; the stored trials' schema
    outputs.py   Table 1's table, plots and final-scene renders
"""
