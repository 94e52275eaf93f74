"""``SVRMPCSettings`` in groups, a trial's params flat: flat -> nested -> flat gives every
committed MPC trial's params back (older params: the missing settings at the defaults they ran
with), and property-generated params too, each setting landing in its group; a row applies
over the nested form as it did over the flat one; every group documents its fields (the
flags' help text)."""

from dataclasses import fields, replace

from hypothesis import given, settings
from hypothesis import strategies as st

from dopt.lab.flags import field_docs, field_paths
from dopt.lab.provenance import rooted
from planners.ilqr import Derivatives
from planners.svr_mpc import (
    TABLE1_ROWS,
    DofSelection,
    Execution,
    PushScene,
    PushStart,
    SVRMPCSettings,
    Timing,
    legacy_trial_key,
    parse_row,
    split_params,
    trial_params,
)
from planners.svr_mpc.settings import GROUPS, RECORD_NAMES
from tests.planners.svr_mpc.test_derivative_spelling import _committed

#: the reference: the flat settings and their defaults, in their order, as the flat
#: SVRMPCSettings declared them before the groups (main at d8e3db5)
FLAT_DEFAULTS = {
    "task": "clutter", "method": "svr-sum", "rho": 1.0, "theta": None, "slowdown": None,
    "timeout": None, "feedback": False, "control_noise": 0.0, "synchronous": False,
    "threads": 0, "cost": "ee", "warm_start": False, "clock": "real", "nominal_threads": 2.0,
    "fd_centered": False, "fd_eps": 1e-3, "keypoints": "every", "fd_skip": 1, "box_qp": False,
    "problem": "ours", "layouts": None, "islands": True, "push_tail": True, "clock_ms": None,
    "executor": "alg1", "keep_costed": False, "mu_reset": False}

#: where each flat setting lives in the groups (the design, written out by hand)
GROUP_OF = {"method": "selection", "rho": "selection", "theta": "selection",
            "keep_costed": "selection", "problem": "scene", "layouts": "scene",
            "islands": "scene", "warm_start": "start", "push_tail": "start", "clock": "timing",
            "nominal_threads": "timing", "clock_ms": "timing", "slowdown": "timing",
            "synchronous": "timing", "executor": "execution", "feedback": "execution",
            "control_noise": "execution", "timeout": "execution"}
DERIVATIVE_FIELDS = ("fd_centered", "fd_eps", "keypoints", "fd_skip", "box_qp")


def _same_values(a: dict, b: dict) -> bool:
    """Equal, key order and value types included (a trial file keeps both)."""
    return list(a) == list(b) and all(
        a[k] == b[k] and type(a[k]) is type(b[k]) for k in a)


def test_every_committed_trials_params_come_back_flat():
    """Every committed MPC trial's params; those on the authors' layouts only where their
    folder is here (the settings check it; ../shared/external is not part of the project)."""
    n = 0
    for record in _committed():
        p = record["params"]
        if "rho" not in p:
            continue                                   # a pick-and-place trial
        if p.get("layouts") is not None and not rooted(p["layouts"]).is_dir():
            continue                                   # the authors' data is absent
        s, seed, optimiser = split_params(p)
        assert isinstance(s.timing, Timing) and isinstance(s.derivatives, Derivatives)
        q = trial_params(s, seed, optimiser)
        assert {k: q[k] for k in p} == p and all(type(q[k]) is type(p[k]) for k in p)
        assert all(q[k] == FLAT_DEFAULTS[k] for k in q if k not in p)   # an older record
        assert [k for k in q if k in FLAT_DEFAULTS] == list(FLAT_DEFAULTS)
        assert legacy_trial_key(q) == record["key"]
        n += 1
    assert n > 1000, n


def test_the_record_names_are_the_flat_settings_in_their_order():
    assert RECORD_NAMES == tuple(FLAT_DEFAULTS)
    assert _same_values(SVRMPCSettings().params(), FLAT_DEFAULTS)
    leaves = {p.rsplit(".", 1)[-1] for p in field_paths(SVRMPCSettings)}
    assert leaves ^ set(RECORD_NAMES) == {"fd", "fd_centered"}   # Derivatives names its own


# ---------------------------------------------------------- property-generated settings
positive = st.floats(1e-3, 1e3, allow_nan=False, allow_infinity=False)
optional = lambda s: st.none() | s                                           # noqa: E731


@st.composite
def flat_params(draw) -> dict:
    """Valid flat settings, drawn from what each means (not from the library's tables)."""
    task = draw(st.sampled_from(["clutter", "soft", "soft_rigid"]))
    clock = draw(st.sampled_from(["real", "virtual", "model", "authors"]))
    problem = draw(st.sampled_from(["ours", "authors"]))
    fd_centered, fd_eps = draw(st.sampled_from([(False, 1e-3), (True, 1e-6), (False, 1e-4),
                                                (True, 3e-5)]))
    keypoints = draw(st.sampled_from(["every", "skip", "adaptive"]))
    return {
        "task": task,
        "method": draw(st.sampled_from(["baseline", "rand", "naive", "svr-sum", "svr-svd"])),
        "rho": draw(st.floats(0.0, 1e3)), "theta": draw(optional(st.integers(0, 60))),
        "slowdown": draw(optional(positive)), "timeout": draw(optional(st.integers(1, 5000))),
        "feedback": draw(st.booleans()), "control_noise": draw(st.floats(0.0, 1.0)),
        "synchronous": clock == "real" and draw(st.booleans()),
        "threads": draw(st.integers(0, 16)),
        "cost": draw(st.sampled_from(["ee", "paper", "paper-reach", f"authors-{task}"])),
        "warm_start": draw(st.booleans()), "clock": clock, "nominal_threads": draw(positive),
        "fd_centered": fd_centered, "fd_eps": fd_eps, "keypoints": keypoints,
        "fd_skip": draw(st.integers(1, 40)) if keypoints == "skip" else 1,
        "box_qp": draw(st.booleans()), "problem": problem,
        "layouts": "tests" if (problem, task) == ("authors", "clutter") else None,
        "islands": draw(st.booleans()), "push_tail": draw(st.booleans()),
        "clock_ms": draw(optional(positive)) if clock == "model" else None,
        "executor": draw(st.sampled_from(["alg1", "authors"])),
        "keep_costed": draw(st.booleans()), "mu_reset": draw(st.booleans())}


def _built_by_hand(p: dict) -> SVRMPCSettings:
    """The nested settings of flat ``p``, each group built from its own fields."""
    return SVRMPCSettings(
        task=p["task"], cost=p["cost"], threads=p["threads"], mu_reset=p["mu_reset"],
        selection=DofSelection(p["method"], p["rho"], p["theta"], p["keep_costed"]),
        derivatives=Derivatives("central" if p["fd_centered"] else "forward", p["keypoints"],
                                p["fd_skip"], p["box_qp"], p["fd_eps"]),
        scene=PushScene(p["problem"], p["layouts"], p["islands"]),
        start=PushStart(p["warm_start"], p["push_tail"]),
        timing=Timing(p["clock"], p["nominal_threads"], p["clock_ms"], p["slowdown"],
                      p["synchronous"]),
        execution=Execution(p["executor"], p["feedback"], p["control_noise"], p["timeout"]))


@settings(max_examples=300, deadline=None)
@given(flat_params())
def test_flat_nested_flat_round_trips_and_each_setting_sits_in_its_group(p):
    s = SVRMPCSettings.from_params(p)
    assert s == _built_by_hand(p) == SVRMPCSettings().with_params(**p)
    assert _same_values(s.params(), p)
    assert _same_values(trial_params(s, 7), {**p, "seed": 7})
    again, seed, _ = split_params(trial_params(s, 7))
    assert (again, seed) == (s, 7)
    for name, group in GROUP_OF.items():
        assert getattr(getattr(s, group), name) == p[name], name
    assert s.derivatives.fields() == {k: p[k] for k in DERIVATIVE_FIELDS}
    assert s.selection.config.theta == (p["theta"] if p["theta"] is not None else
                                        {"rand": 5, "svr-sum": 10, "svr-svd": 10}.get(
                                            p["method"], 0))


@settings(max_examples=200, deadline=None)
@given(flat_params(), st.sampled_from(list(TABLE1_ROWS)),
       st.sampled_from(["", "+skip5", "+adaptive+boxqp", "+central", "+costdofs+mureset",
                        "+skip2+central+mureset"]))
def test_a_row_applies_over_the_nested_form_as_over_the_flat(p, name, mods):
    """The reference: the flat Row.apply (main at d8e3db5), the row's method, theta, rho,
    derivative fields (its variants over the settings' own) and fixes set flat."""
    row = parse_row(name + mods)
    d = replace(Derivatives.from_fields(p), **row.variants)
    expected = {**p, "method": row.method, "theta": row.theta, "rho": float(row.rho),
                **d.fields(), **row.fixes}
    applied = row.apply(SVRMPCSettings.from_params(p))
    assert _same_values(applied.params(), expected)
    untouched = {"task", "cost", "threads", "scene", "start", "timing", "execution"}
    assert all(getattr(applied, k) == getattr(SVRMPCSettings.from_params(p), k)
               for k in untouched)


def test_every_group_documents_each_of_its_fields():
    """The flags' help text is a field's line in its group's Attributes (``field_docs``)."""
    for cls in (SVRMPCSettings, *GROUPS.values()):
        assert set(field_docs(cls)) == {f.name for f in fields(cls)}, cls.__name__
        assert all(len(text) > 10 for text in field_docs(cls).values()), cls.__name__
    assert set(GROUPS) == {"selection", "derivatives", "scene", "start", "timing", "execution"}
