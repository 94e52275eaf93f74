"""The drag-encoding sweep in the report (``experiments/fig7_encoding.py``, experiment
"fig7_encoding"; ``report_encoding``): a real smoke run renders its settings, per-N costs,
trials and rebuild; hand-made sweeps give the verdict their statistics call for, checked
against a least-squares fit and Holm's adjustment done here; nothing shows while no file is
recorded."""
import json
import math

import numpy as np
import pytest
from scipy import stats as scipy_stats

from dopt.lab.record import settings_dict
from dopt.lab.report import base
from dopt.lab.report.resummarize import rebuild
from planners.pick_place.drag_settings import DragSettings
from planners.pick_place.encoding import encoding_settings, encoding_summary
from tests.dopt.lab.report.report_site import (
    block,
    fig7,
    headlines,
    make_site,
    provenance,
    run,
    write,
)

TITLE = "## Key particles: the gain against the candidate count under the drag encoding"
CLAIM = "The gain grows with the candidate count under the authors' encoding"
ROW = "Sec. V under the authors' drag encoding"


@pytest.fixture
def site(tmp_path, monkeypatch):
    """A results site (``report_site.make_site``)."""
    return make_site(tmp_path, monkeypatch)


def _page(site) -> str:
    return (site["md"].parent / "KEY-PARTICLES.md").read_text()


def _section(md: str) -> str:
    start = md.index(TITLE)
    end = md.find("\n## ", start + 1)
    return md[start:] if end < 0 else md[start:end]


# ------------------------------------------------------------------ a real smoke run
@pytest.mark.slow
def test_a_quick_run_renders_its_settings_costs_trials_and_rebuild(site):
    from planners.pick_place.experiments import encoding

    out = site["results"] / "runs" / "fig7-encoding-diagonal"
    argv = ["--goal", "diagonal", "--quick", "--trials", "1", "--population", "4",
            "--iterations", "1", "--threads", "1", "--out", str(out)]
    assert encoding.main(argv) == 0
    summary = json.loads((out / "summary.json").read_text())
    # as recorded from the repository: its --out under docs/results/runs (the report finds
    # the trials there)
    command = ("python experiments/fig7_encoding.py " + " ".join(argv[:-1])
               + " docs/results/runs/fig7-encoding-diagonal")
    summary["provenance"]["command"] = command
    path = write(site["results"], "fig7-encoding-diagonal.json", summary)
    assert run(site) == 0
    md = site["md"].read_text()
    text = _section(md)

    # per N and method the trials' own final costs (one seed: no interval), read here
    trials = [json.loads(p.read_text()) for p in sorted((out / "trials").glob("*.json"))]
    assert len(trials) == 5            # Simple once, Original and Random at N 4 and 9
    cost = {(t["params"]["method"].removesuffix("-drag"),
             t["params"]["settings"]["drag"]["n_points"]): t["result"]["final_cost"]
            for t in trials}
    simple = cost["simple", 4]
    for n in (4, 9):
        o, r = cost["original", n], cost["random", n]
        row = (f"| {n} | {math.isqrt(n)} x {math.isqrt(n)} | {simple * 1e3:.1f} (1) | "
               f"{o * 1e3:.1f} (1) | {r * 1e3:.1f} (1) | {(o - simple) * 1e3:.1f} | "
               f"{(r - simple) * 1e3:.1f} |")
        assert row in text, row
    drag = DragSettings()
    assert "one physics mesh of 20 x 20 particles" in text
    assert "N candidate pick points 4, 9" in text
    assert (f"T = {drag.horizon} decisions of {drag.repeat} substeps, each at most "
            f"{drag.step * 1e3:.1f} mm per axis") in text
    assert f"{drag.substeps} MuJoCo steps per substep; CEM population 4, 1 iteration" in text
    assert "the executed plan stopping there (the authors')" in text
    # two values of N and one seed: two paired points, no slope to fit
    assert "- original - simple, 2 paired seeds over 2 values of N: **not testable**" in text
    assert f"`{command}`" in text and "**quick (smoke-sized) run**" in text
    assert "Trials: 5 committed under `runs/fig7-encoding-diagonal/`" in text
    assert "Stale" not in text and "## Fig. 7 sweeps in progress" not in md
    # a quick run has its headline, but no README row and no claim on the paper's page
    assert "Sec. V under the authors' drag encoding, diagonal fold (quick run)" in headlines(site)
    assert ROW not in block(site["readme"]) and CLAIM not in _page(site)

    # the summary rebuilt from its committed trials is the one the run wrote
    found = rebuild(site["results"], base.Result(path, summary))
    assert found["error"] is None and not found["diff"]["differs"], found["diff"]
    assert not found["diff"]["missing"]

    # settings that today's code no longer gives: a drag default no flag of the command set,
    # and one N's physics
    summary = json.loads(path.read_text())
    for s in summary["settings"].values():
        s["drag"]["horizon"] = drag.horizon + 1
    summary["physics"]["9"]["scene"]["timestep"] = 0.004
    write(site["results"], path.name, summary)
    assert run(site) == 0
    text = _section(site["md"].read_text())
    assert f"the drag encoding's defaults now set horizon {drag.horizon + 1} → {drag.horizon}" \
        in text
    assert "at N 9 its physics now resolves to scene.timestep 0.004 → 0.005" in text


# -------------------------------------------------------------- hand-made sweeps
POINTS = (100, 400, 1600, 10000)


def _records(rng: np.random.Generator, slope: float, seeds=range(5)) -> list[dict]:
    """Sweep records as ``dopt.lab.sweep`` keeps them (the fields ``encoding_summary``
    reads): CEM(Simple) once per seed at the smallest N, Original and Random at every N,
    Original - Simple = ``slope`` * log N + noise (m), Random - Simple noise alone."""
    out = []
    for seed in seeds:
        base_cost = 0.02 + 0.002 * rng.random()
        out.append(_record("simple-drag", POINTS[0], seed, base_cost))
        for n in POINTS:
            out.append(_record("original-drag", n, seed,
                               base_cost + 0.005 + slope * math.log(n)
                               + 0.0005 * rng.standard_normal()))
            out.append(_record("random-drag", n, seed,
                               base_cost + 0.003 + 0.0005 * rng.standard_normal()))
    return out


def _record(method: str, n: int, seed: int, cost: float) -> dict:
    return {"params": {"settings": {"drag": {"n_points": n}}, "method": method, "seed": seed},
            "result": {"final_cost": cost, "unstable": False}}


def _summary(goal: str, records: list[dict]) -> dict:
    """A result file as ``fig7_encoding.py`` writes it, its settings today's."""
    settings = {n: encoding_settings(goal, DragSettings(n_points=n)) for n in POINTS}
    return {"experiment": "fig7_encoding", "task": "cloth", "goal": goal, "protocol": "paper",
            "encoding": "drag", "points": list(POINTS), "seeds": list(range(5)),
            "methods_run": ["simple-drag", "original-drag", "random-drag"],
            "settings": {str(n): settings_dict(s) for n, s in settings.items()},
            "physics": {str(n): s.resolved_physics() for n, s in settings.items()},
            **encoding_summary(records, POINTS), "failed": {},
            "provenance": provenance(f"python experiments/fig7_encoding.py --goal {goal}")}


def _fit(records: list[dict], method: str) -> tuple[float, float]:
    """(slope, two-sided p) of method - Simple per seed on log N, by least squares here."""
    simple = {r["params"]["seed"]: r["result"]["final_cost"] for r in records
              if r["params"]["method"] == "simple-drag"}
    x, y = [], []
    for r in records:
        if r["params"]["method"] == method:
            x.append(math.log(r["params"]["settings"]["drag"]["n_points"]))
            y.append(r["result"]["final_cost"] - simple[r["params"]["seed"]])
    x, y = np.array(x), np.array(y)
    slope, intercept = np.polyfit(x, y, 1)
    residual = y - (slope * x + intercept)
    se = math.sqrt(residual @ residual / (len(x) - 2) / ((x - x.mean()) @ (x - x.mean())))
    return slope, 2 * scipy_stats.t.sf(abs(slope / se), len(x) - 2)


def _holm(ps: list[float]) -> list[float]:
    order = sorted(range(len(ps)), key=ps.__getitem__)
    out, running = [0.0] * len(ps), 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (len(ps) - rank) * ps[i]))
        out[i] = running
    return out


def test_a_steep_trend_holds_and_a_flat_one_is_not_shown(site):
    rng = np.random.default_rng(7)
    steep = _records(rng, slope=0.004)
    write(site["results"], "fig7-encoding-diagonal.json", _summary("diagonal", steep))
    assert run(site) == 0
    text = _section(site["md"].read_text())
    (so, po), (sr, pr) = _fit(steep, "original-drag"), _fit(steep, "random-drag")
    holm = _holm([po, pr])
    assert po < 1e-6 and holm[0] < 0.05
    assert (f"- original - simple, 20 paired seeds over 4 values of N: slope {so * 1e3:.1f} ± "
            f"") in text
    assert f"Holm p {holm[0]:.3f}: **grows**" in text
    assert (f"- random - simple, 20 paired seeds over 4 values of N: slope {sr * 1e3:.1f} ± "
            ) in text and f"Holm p {holm[1]:.3f}: **" in text
    page = _page(site)
    assert f"[{CLAIM}](#" in page and "**holds**" in page.split(f"### {CLAIM}")[1]
    row = next(line for line in block(site["readme"]).splitlines() if ROW in line)
    assert f"diagonal grows ({so * 1e3:.1f} ± " in row
    assert "(N 100-10000, 5 seeds)" in row

    flat = _records(np.random.default_rng(8), slope=0.0)
    write(site["results"], "fig7-encoding-diagonal.json", _summary("diagonal", flat))
    assert run(site) == 0
    assert _fit(flat, "original-drag")[1] > 0.05
    claim = _page(site).split(f"### {CLAIM}")[1]
    assert "*Verdict:* **not shown**" in claim and "diagonal no trend (" in claim
    assert "**no trend detected at 95 %**" in _section(site["md"].read_text())


def test_a_shrinking_gap_does_not_hold_and_two_folds_are_one_holm_family(site):
    rng = np.random.default_rng(11)
    side = _records(rng, slope=-0.004)
    diagonal = _records(rng, slope=0.004)
    write(site["results"], "fig7-encoding-side.json", _summary("side", side))
    assert run(site) == 0
    assert "*Verdict:* **does not hold**" in _page(site).split(f"### {CLAIM}")[1]
    write(site["results"], "fig7-encoding-diagonal.json", _summary("diagonal", diagonal))
    assert run(site) == 0
    # Holm over the four tests of both folds, adjusted here
    ps = [_fit(recs, m)[1] for recs in (diagonal, side)
          for m in ("original-drag", "random-drag")]
    adjusted = _holm(ps)
    text = _section(site["md"].read_text())
    assert f"Holm p over the 4 tests of the 2 folds {adjusted[0]:.3f}: **grows**" in text
    assert f"Holm p over the 4 tests of the 2 folds {adjusted[2]:.3f}: **shrinks**" in text
    assert "*Verdict:* **partly holds**" in _page(site).split(f"### {CLAIM}")[1]
    row = next(line for line in block(site["readme"]).splitlines() if ROW in line)
    assert "; Holm over 4 tests |" in row and "diagonal grows" in row and "side shrinks" in row


def test_nothing_shows_while_no_encoding_file_is_recorded(site):
    """Its catalogue entries, README row and claim are hidden, not "not recorded yet"."""
    rng = np.random.default_rng(3)
    write(site["results"], "fig7_cloth_diagonal.json", fig7())
    write(site["results"], "fig7-encoding-diagonal.json",
          _summary("diagonal", _records(rng, 0.004)))
    assert run(site) == 0
    assert ROW in block(site["readme"]) and CLAIM in _page(site)
    (site["results"] / "fig7-encoding-diagonal.json").unlink()
    assert run(site) == 0
    assert "not recorded yet" in headlines(site)           # the other experiments' entries
    for text in (site["md"].read_text(), _page(site), block(site["readme"])):
        assert "drag encoding" not in text and "candidate count" not in text


def _drag_record(picks, n_points, side=0.5, method="original-drag"):
    """A drag trial record with the fields ``pick_spread`` reads."""
    return {"params": {"settings": {"side": side, "drag": {"n_points": n_points}}},
            "result": {"method": method, "actions": [{"particles": list(map(int, picks))}]}}


def test_uniform_pair_constant_matches_monte_carlo():
    """The square line picking constant against a Monte-Carlo estimate (its standard error
    is about 0.25 / sqrt(n), 0.0004 here)."""
    from planners.pick_place.experiments.report_encoding import UNIFORM_PAIR

    rng = np.random.default_rng(0)
    a, b = rng.random((400_000, 2)), rng.random((400_000, 2))
    assert np.linalg.norm(a - b, axis=1).mean() == pytest.approx(UNIFORM_PAIR, abs=0.002)


def test_pick_spread_measures_grid_distances():
    """Opposite corners of the grid lie one side apart (a None pick between them skipped);
    a point picked again is 0 apart; other methods' trials and unreadable records are left
    out; trials of one N are averaged."""
    from planners.pick_place.experiments.report_encoding import pick_spread

    m = 7
    recs = [_drag_record([0, -1, m - 1], m * m, side=0.4),       # (0, 0) -> (0, 6): 0.4 m
            _drag_record([3, 3, 3], m * m, side=0.4),            # held: 0
            _drag_record([0, m * m - 1], m * m, side=0.4, method="simple-drag"),
            {"result": {"method": "original-drag"}},
            _drag_record([5], 16)]                               # one pick: no distance
    assert pick_spread(recs) == {m * m: (pytest.approx(0.2), 2)}


def test_pick_spread_of_uniform_picks_is_the_uniform_pair_distance():
    """Picks drawn independently and uniformly over a fine grid (a generator of this test's
    own) lie UNIFORM_PAIR x side apart on average, to the grid's and the sample's error."""
    from planners.pick_place.experiments.report_encoding import UNIFORM_PAIR, pick_spread

    rng = np.random.default_rng(1)
    n = 200 * 200
    out = pick_spread([_drag_record(rng.integers(0, n, 50_000), n, side=0.6)])
    assert out[n][0] == pytest.approx(UNIFORM_PAIR * 0.6, rel=0.01)


def _plan_record(method, picks, final, history, seed=0, n_points=100):
    """A drag trial record with the fields ``plan_diagnostics`` reads."""
    rec = _drag_record(picks, n_points, method=method)
    rec["result"].update(final_cost=final, cost_history=list(history), seed=seed)
    return rec


def test_plan_diagnostics_counts_kept_points_and_the_release_gap():
    """Kept pairs: the same point twice in a row, a None pair (-1, -1) not kept; the gap: the
    final cost minus the lowest of the history, its largest with its seed and N; methods in
    the table's order, other records skipped."""
    from planners.pick_place.experiments.report_encoding import plan_diagnostics

    recs = [_plan_record("original-drag", [4, 4, 7, -1, -1], 0.10, [0.2, 0.09], seed=1,
                         n_points=400),                         # pairs 4, kept 1, gap +0.01
            _plan_record("original-drag", [2, 3], 0.05, [0.08, 0.06], seed=2),  # gap -0.01
            _plan_record("simple-drag", [1, 1, 1], 0.07, [0.07]),   # pairs 2, kept 2, gap 0
            _plan_record("simple", [1, 1], 0.01, [0.01]),            # not a drag trial
            {"result": {"method": "random-drag"}}]                   # unreadable
    out = plan_diagnostics(recs)
    assert list(out) == ["simple", "original"]
    o = out["original"]
    assert (o["trials"], o["pairs"]) == (2, 5)
    assert o["carried"] == pytest.approx(1 / 5)
    assert o["final"] == pytest.approx(0.075)
    assert o["held_gap"] == pytest.approx(0.0)
    assert o["largest"] == {"gap": pytest.approx(0.01), "seed": 1, "n_points": 400}
    assert out["simple"]["carried"] == 1.0 and out["simple"]["held_gap"] == 0.0


def test_plan_diagnostics_of_independent_uniform_picks_keep_one_in_n():
    """Picks drawn independently and uniformly over N points (this test's own generator)
    pick the previous point again once in N, to the sample's error."""
    from planners.pick_place.experiments.report_encoding import plan_diagnostics

    rng = np.random.default_rng(2)
    picks = rng.integers(0, 10, 100_000)
    out = plan_diagnostics([_plan_record("random-drag", picks, 0.1, [0.1], n_points=10)])
    assert out["random"]["carried"] == pytest.approx(0.1, abs=0.005)
