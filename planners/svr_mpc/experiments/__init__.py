"""The state-vector-reduction paper's experiments: one object per figure or table (its flags,
settings, trials, summary and report section), registered once for the report
(``dopt.lab.experiment``); ``experiments/`` keeps a thin command line over each."""
