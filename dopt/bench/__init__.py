"""Benchmarks: ``python -m dopt.bench NAME [...]`` prints one JSON object per measurement.

Every timing comes with a ratio measured in the same run: against the physical limit (the pure
``mj_step`` cost of the steps it needed, divided by the threads) or against a baseline. The
benches here measure the runtime alone (rollouts, derivatives); the planner benches live in
``planners.bench`` and reuse ``dopt.bench.timing`` and ``dopt.bench.cli``. Modules:

    __main__.py     the subcommands rollout, derivatives, cloth-steps, cloth-warp
    rollout.py      batched rollouts and reduced FD derivatives against the physical limit
    cloth_steps.py  a cloth step across resolutions and physics presets, MuJoCo's own timers
    cloth_warp.py   a cloth action on MuJoCo Warp (an optional GPU) beside the CPU step
    timing.py       small timing helpers; cli.py the flags every bench takes, --record
"""
