"""Every command recorded in docs/results (the result files' provenance, and the commands
they keep of earlier runs) that runs an SVR experiment still parses with today's flags: a
renamed flag keeps its old spelling as a hidden alias (--methods for --rules, --method for
--rule) with the same meaning and a deprecation line. The recorded Table 1 commands also make
today the trials their summaries list (``trial_keys``): each found under its name, or under its
older one (``Schema.aliases``), so the committed trials resolve."""
import json
import logging
import shlex
from pathlib import Path

import pytest

from planners.svr_mpc.experiments import clock_check, explain, fig4, mapping, table1

ROOT = Path(__file__).resolve().parents[4]
RESULTS = ROOT / "docs" / "results"
#: script -> its experiment's parser
PARSERS = {"mpc.py": table1.parser, "rho_sweep.py": fig4.parser,
           "svr_explain.py": explain.parser, "clock_check.py": clock_check.parser}


def strings(value):
    """Every string inside a JSON value."""
    if isinstance(value, str):
        yield value
    elif isinstance(value, dict):
        for v in value.values():
            yield from strings(v)
    elif isinstance(value, list):
        for v in value:
            yield from strings(v)


def recorded() -> list[tuple[str, str, list[str]]]:
    """(result file, script, argv) of every recorded command of an SVR experiment."""
    out = set()
    for path in sorted(RESULTS.glob("*.json")):
        for text in strings(json.loads(path.read_text())):
            words = text.split(maxsplit=2)
            if len(words) >= 2 and words[0] == "python" and \
                    words[1].removeprefix("experiments/") in PARSERS:
                argv = shlex.split(text)
                out.add((path.name, argv[1].removeprefix("experiments/"), tuple(argv[2:])))
    return [(name, script, list(argv)) for name, script, argv in sorted(out)]


COMMANDS = recorded()


def test_the_recorded_commands_cover_every_svr_result_family():
    files = {name for name, _, _ in COMMANDS}
    for family in ("table1-", "fig4-", "clock-check-", "svr-explain-"):
        assert any(f.startswith(family) for f in files), family
    assert {script for _, script, _ in COMMANDS} == set(PARSERS)


@pytest.mark.parametrize("name, script, argv", COMMANDS,
                         ids=[f"{n}:{' '.join(a)[:60]}" for n, _, a in COMMANDS])
def test_a_recorded_command_parses_with_todays_flags(name, script, argv, monkeypatch):
    monkeypatch.chdir(ROOT)                     # --out and --record are the repository's
    args = PARSERS[script]().parse_args(argv)
    assert args.task in ("clutter", "soft", "soft_rigid")
    if "--trials" in argv:
        assert args.trials == int(argv[argv.index("--trials") + 1])


def test_the_old_spellings_mean_the_new_flags(tmp_path, caplog):
    out = ["--out", str(tmp_path / "o"), "--trials", "2"]
    with caplog.at_level(logging.WARNING):
        old = table1.parse_args(["--methods", "baseline,svr-svd", "--theta", "3", *out])
    assert "--methods is the old spelling of --rules" in caplog.text
    new = table1.parse_args(["--rules", "baseline,svr-svd", "--theta", "3", *out])
    assert old.rules == new.rules == ["baseline", "svr-svd"] and not hasattr(old, "methods")
    assert [t.key for t in mapping.make_trials(old)] == [t.key for t in mapping.make_trials(new)]
    assert len(mapping.make_trials(new)) == 2 * 2
    ap = fig4.parser()
    assert ap.parse_args(["--method", "svr-svd"]).rule == "svr-svd"
    assert ap.parse_args([]).rule == "svr-sum"
    assert "--method " not in ap.format_help() and "--methods" not in table1.parser().format_help()


#: Table 1 results recorded by their own command (a resummarized file's command is
#: resummarize's)
TABLE1 = sorted(name for name, script, argv in COMMANDS
                if script == "mpc.py" and name.startswith("table1-")
                and "resummarize" not in json.loads((RESULTS / name).read_text())
                ["provenance"]["command"])


@pytest.mark.parametrize("name", TABLE1)
def test_a_recorded_table1_command_makes_the_keys_of_its_committed_trials(name, monkeypatch):
    """The trials today's flags make are the committed trials (loose or packed, found under
    their older names) and those the summary lists: a rerun of the command reuses them,
    resummarize finds them (where the command's preset still means the protocol the summary
    records)."""
    from dopt.lab.sweep import load_finished
    from dopt.lab.sweep_store import find_alias
    from planners.svr_mpc.experiments.flags import quick_defaults
    from planners.svr_mpc.experiments.runner import SCHEMA

    data = json.loads((RESULTS / name).read_text())
    argv = shlex.split(data["provenance"]["command"])[2:]
    monkeypatch.chdir(ROOT)
    args = table1.parser().parse_args(argv)     # its own parse: --layouts need not be here
    if args.layouts is not None and not (ROOT / args.layouts).is_dir():
        pytest.skip(f"{name}: the authors' scenes ({args.layouts}) are absent")
    quick_defaults(args)
    args.threads = args.threads or 0
    trials = mapping.make_trials(args)
    then = mapping.protocol(args, trials[0].params)
    recorded = {"executor": "alg1", **data}     # a summary before the executor had Alg. 1's
    if any(recorded.get(k, v) != v for k, v in then.items()):
        pytest.skip(f"{name}: its preset meant another protocol then (report_stale's case)")
    committed = load_finished(ROOT / argv[argv.index("--out") + 1])
    # each trial under its own name, else under its older one (the committed trials' names)
    stored = {t.key: t.key if t.key in committed else find_alias(committed, t.params, SCHEMA)
              for t in trials}
    missing = sorted(k for k, v in stored.items() if v is None)
    assert stored and not missing, missing[:3]
    assert set(stored.values()) == set(data.get("trial_keys", stored.values()))
