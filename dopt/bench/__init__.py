"""Benchmarks: ``python -m dopt.bench NAME [...]`` prints one JSON object per measurement.

Every timing comes with a ratio measured in the same run: against the physical limit (the pure
``mj_step`` cost of the steps it needed, divided by the threads) or against a baseline. This
package is a command-line entry point, the top of the house like ``experiments/``: it may load
planner benches lazily, the library modules under ``dopt`` never do.
"""
