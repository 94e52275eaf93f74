"""Planner benchmarks: ``python -m planners.bench {ilqr,cem} [...]`` prints one JSON object per
measurement, with a ratio measured in the same run (against the physical limit or a baseline),
as ``python -m dopt.bench`` does for the runtime alone."""
