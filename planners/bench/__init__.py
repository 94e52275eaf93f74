"""Planner benchmarks: ``python -m planners.bench
{ilqr,clock,cem,cem-limit,settle,cloth,rope} [...]`` prints one JSON object per measurement
(``cem-limit``: a table, one line per cloth size), with a ratio measured in the same run
(against the physical limit or a baseline), as ``python -m dopt.bench`` does for the runtime
alone; ``--record`` writes a result file."""
