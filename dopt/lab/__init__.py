"""dopt.lab: the research machinery beside the runtime (sweeps, trial files, provenance,
statistics, command lines). It knows no physics: of the rest of dopt it imports only the
package front, ``dopt.validation`` and ``dopt.atomic``, and nothing of the runtime imports it
(tests/test_layers.py), so a reader who wants a planning library reads ``dopt`` and one who
runs sweeps reads this room. Modules:

    sweep.py                resumable trial sweeps (inline, process pool, Ray): schemas,
                            checkpoints, interrupts; ``python -m dopt.lab.sweep pack OUT``
    sweep_store.py          the trial folder: records, checkpoints, the corrupt bin
    sweep_exec.py           the runners of one trial; sweep_pool.py: the worker pool
    sweep_lock.py           the folder's lock and the workers it knows
    sweep_pack.py           loose trial files into the append-only ``pack.jsonl``
    trialpack.py            the one reader of stored trials, loose or packed
    jsonio.py               strict JSON (no bare NaN), atomic writes
    provenance.py           command, commit, versions of a result; the recording and reuse rules
    stats.py, multiple.py   means and intervals; Holm's correction
    cli.py                  the command lines' shared types and ``guarded()``
    record.py               what a run writes and when: OUT/summary.json, --record and its
                            refusals, --reuse-any
    console.py              a sweep's console: progress bar, estimates, finished lines
    scripts.py              the console scripts (dopt-fold, dopt-mpc, ...) over experiments/
    dicts.py                small helpers on nested JSON-like dicts
    identity.py             the one trial identity of both papers: a trial's name, the hash
                            of the settings that differ from a fixed reference

Standard library only, but numpy in stats.py (Ray, for a sweep across machines, is optional)."""
