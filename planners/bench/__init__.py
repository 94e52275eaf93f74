"""Planner benchmarks: ``python -m planners.bench
{ilqr,clock,cem,cem-limit,settle,cloth,rope,reference} [...]`` prints one JSON object per
measurement (``cem-limit``: a table, one line per cloth size), with a ratio measured in the same run
(against the physical limit or a baseline), as ``python -m dopt.bench`` does for the runtime
alone; ``--record`` writes a result file (ilqr, cem-limit, settle, cloth, rope: the ones
RESULTS.md cites). Modules:

    __main__.py  the subcommands; ilqr.py iLQR(-SVR) iterations per DoF selector; clock.py the
                 model clock's fit; cem.py a CEM iteration and its physical limit per cloth
                 size; settle.py what settling until at rest cuts; physics.py the rope and
                 cloth physics presets (speed, blow-ups, scripted-fold error);
                 reference.py the presets against analytic references (catenary, cantilever,
                 hanging sheet; cosseratbench, a dev dependency)
"""
