"""One flag vocabulary (issue 91 item 3): every script in experiments/ shows in its --help
only the vocabulary's names for the shared concepts (--trials, --goal, --n, --rules, --rule;
the old spellings are hidden aliases), and every sweep script, the key-particle and the SVR
ones, has the sweep's flags. The
--help of each script is read as ``python experiments/X.py --help`` prints it (run in-process
as ``__main__``, the way the console scripts run them)."""
from __future__ import annotations

import contextlib
import io
import runpy
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXPERIMENTS = ROOT / "experiments"
SCRIPTS = sorted(p.name for p in EXPERIMENTS.glob("*.py"))
#: old spelling -> the vocabulary's word (shown nowhere; a hidden alias at most)
OLD = {"--seeds": "--trials", "--goals": "--goal", "--cloth-n": "--n"}
#: old spellings of one script (the same word means something else elsewhere: the pick
#: scripts' --methods are planners): script -> {old: the vocabulary's word}
OLD_IN = {"mpc.py": {"--methods": "--rules"}, "rho_sweep.py": {"--method": "--rule"}}
#: the flags every sweep script has
SWEEP_FLAGS = ("--out", "--record", "--fresh", "--reuse-any", "--workers", "--threads",
               "--quick", "-v")
#: the key-particle scripts that run a sweep of trials
PICK_SWEEPS = ("cloth_fold.py", "rope.py", "fig7_scaling.py", "fig7_encoding.py",
               "panda_execute.py")
#: the state-vector-reduction scripts that run a sweep of MPC trials
SVR_SWEEPS = ("mpc.py", "rho_sweep.py", "svr_explain.py", "clock_check.py")


def help_text(script: str) -> str | None:
    """What ``python experiments/<script> --help`` prints; None for a module that is no
    script (it exits without printing help)."""
    out = io.StringIO()
    saved = sys.argv[:]
    sys.argv = [str(EXPERIMENTS / script), "--help"]
    try:
        with contextlib.redirect_stdout(out), contextlib.suppress(SystemExit):
            runpy.run_path(str(EXPERIMENTS / script), run_name="__main__")
    finally:
        sys.argv = saved
    text = out.getvalue()
    return text if "usage:" in text else None


def shown_flags(text: str) -> set[str]:
    """Every option string of the help's option lines."""
    flags = set()
    for line in text.splitlines():
        for word in line.replace(",", " ").replace("[", " ").replace("]", " ").split():
            if word.startswith("-") and len(word) > 1 and not word[1].isdigit():
                flags.add(word.split("=")[0])
    return flags


@pytest.mark.parametrize("script", SCRIPTS)
def test_no_old_spelling_is_shown(script):
    text = help_text(script)
    if text is None:
        pytest.skip(f"{script} is no command line")
    shown = shown_flags(text)
    table = {**OLD, **OLD_IN.get(script, {})}
    old = sorted(f for f in table if f in shown)
    assert not old, f"{script} shows {old}; the vocabulary says {[table[f] for f in old]}"


@pytest.mark.parametrize("script, old", [(s, o) for s, t in OLD_IN.items() for o in t])
def test_a_renamed_flag_is_the_new_one_under_its_old_spelling(script, old):
    """The vocabulary's word is shown and the old spelling is not (that the old one still
    parses as the new: tests/planners/svr_mpc/experiments/test_recorded_commands.py)."""
    new = OLD_IN[script][old]
    shown = shown_flags(help_text(script))
    assert new in shown and old not in shown


@pytest.mark.parametrize("script", PICK_SWEEPS + SVR_SWEEPS)
def test_every_sweep_script_has_the_sweep_flags(script):
    shown = shown_flags(help_text(script))
    assert set(SWEEP_FLAGS) <= shown, sorted(set(SWEEP_FLAGS) - shown)
    assert {"--trials", "--seed"} <= shown


def test_the_checker_sees_flags():
    """The parser of the help text finds what argparse prints, and an old spelling."""
    text = ("usage: x.py [-h] [--seeds SEEDS] [--n N]\n\noptions:\n  -h, --help  show\n"
            "  --seeds SEEDS  seeds\n  --n N   sizes -1 (default -1)\n")
    assert shown_flags(text) == {"-h", "--help", "--seeds", "--n"}
