"""Benchmarks: ``python -m dopt.bench NAME [...]`` prints one JSON object per measurement.

Every timing comes with a ratio measured in the same run: against the physical limit (the pure
``mj_step`` cost of the steps it needed, divided by the threads) or against a baseline. The
benches here measure the runtime alone (rollouts, derivatives); the planner benches live in
``planners.bench`` and reuse ``dopt.bench.timing`` and ``dopt.bench.cli``.
"""
