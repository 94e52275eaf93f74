"""The README map's commands run as written: each experiment's flags, as the map gives them,
pass the script's own checks, and a command without --out writes under results/ (a folder
named for the script and its task) rather than stopping on a missing flag. The run itself
stops right after the flags are checked, so nothing is simulated."""
from __future__ import annotations

import importlib
import shlex
from pathlib import Path

import pytest

from dopt.lab.report import map as lab_map
from tests.external import LAYOUTS

#: the map's placeholder for the authors' data, per flag: the folder it stands for
DIRS = {"--layouts": LAYOUTS}
#: where a script's flags are checked last (the module whose ``check_outputs`` it calls)
CHECKED_IN = {**dict.fromkeys(("mpc", "rho_sweep", "svr_explain", "clock_check"),
                             "planners.svr_mpc.experiments.flags"),
              "rope": "planners.pick_place.experiments.fig7",
              "cloth_fold": "planners.pick_place.experiments.fig7",
              "key_particles": "planners.pick_place.experiments.key_particles",
              "fig7_scaling": "planners.pick_place.experiments.scaling",
              "fig7_encoding": "planners.pick_place.experiments.encoding",
              "panda_execute": "planners.pick_place.experiments.panda_execute"}


class Parsed(SystemExit):
    """Raised in place of the run once the flags passed every check; holds the namespace."""

    def __init__(self, args):
        super().__init__(0)
        self.namespace = args


def experiment_commands() -> list[tuple[str, list[str]]]:
    """(script stem, argv) of every map row that runs an experiments/ script."""
    out = []
    for row in lab_map.rows():
        words = shlex.split(row.command)
        if words[:1] == ["python"] and words[1].startswith("experiments/"):
            out.append((Path(words[1]).stem, words[2:]))
    return out


def test_the_map_names_experiment_scripts():
    """The parametrised test below covers something: most rows run an experiments/ script."""
    assert len(experiment_commands()) >= len(lab_map.rows()) - 2


@pytest.mark.parametrize("script,argv", experiment_commands(),
                         ids=[" ".join([s, *a]) for s, a in experiment_commands()])
def test_map_command_passes_its_checks(script, argv, tmp_path, monkeypatch):
    argv = list(argv)
    for i, word in enumerate(argv[:-1]):
        if argv[i + 1] == "DIR":
            if not DIRS[word].is_dir():
                pytest.skip(f"{DIRS[word]} is absent (the authors' data)")
            argv[i + 1] = str(DIRS[word])
    module = importlib.import_module(script)
    checker = importlib.import_module(CHECKED_IN.get(script, script))
    real = checker.check_outputs

    def check_then_stop(ap, args, default, **kwargs):
        real(ap, args, default, **kwargs)
        raise Parsed(args)

    monkeypatch.setattr(checker, "check_outputs", check_then_stop)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(Parsed) as stopped:
        module.main(argv)
    assert stopped.value.namespace.out.parent == Path("results"), stopped.value.namespace.out
    assert not (tmp_path / "results").exists(), "checking the flags created the folder"
