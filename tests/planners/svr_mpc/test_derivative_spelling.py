"""Derivative options as one typed value (``planners.ilqr.Derivatives``) spelled by one function
(``spell_derivatives``): the legacy keys and row labels it spells are today's, for every row
the command lines accept and for every committed trial, so stored trials are found again."""

import gzip
import itertools
import json
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planners.ilqr import Derivatives, ILQRConfig
from planners.svr_mpc import (
    TABLE1_ROWS,
    SVRMPCSettings,
    legacy_trial_key,
    parse_row,
    parse_variants,
    row_label,
    spell_derivatives,
    trial_key,
    trial_params,
)

RUNS = Path(__file__).resolve().parents[3] / "docs" / "results" / "runs"


# ------------------------------------ the reference: the spellings before the one value
def _old_fields(fd, keypoints, fd_skip, box_qp):
    centred, eps = {"forward": (False, 1e-3), "central": (True, 1e-6)}[fd]
    return {"fd_centered": centred, "fd_eps": eps, "keypoints": keypoints, "fd_skip": fd_skip,
            "box_qp": box_qp}


def _old_key_parts(p):
    parts = []
    if p.get("fd_centered") or p.get("fd_eps", 1e-3) != 1e-3:
        parts.append(f"fd{'c' if p.get('fd_centered') else 'f'}{p.get('fd_eps', 1e-3):g}")
    if p.get("keypoints", "every") != "every":
        parts.append("kpadaptive" if p["keypoints"] == "adaptive"
                     else f"skip{p.get('fd_skip', 1)}")
    if p.get("box_qp"):
        parts.append("boxqp")
    return parts


def _old_tag(p):
    tag = ""
    if p.get("fd_centered") or p.get("fd_eps", 1e-3) != 1e-3:
        tag += " +central" if p.get("fd_centered") else f" +fd{p['fd_eps']:g}"
    if p.get("keypoints", "every") == "adaptive":
        tag += " +adaptive"
    elif p.get("keypoints", "every") == "skip" and p.get("fd_skip", 1) > 1:
        tag += f" +skip{p['fd_skip']}"
    return tag + (" +boxqp" if p.get("box_qp") else "")


def _check_against_old(p):
    """The key's and the label's derivative words are the old spellings'."""
    d = Derivatives.from_fields(p)
    assert list(spell_derivatives(d, "key")) == _old_key_parts(p)
    assert "".join(f" +{w}" for w in spell_derivatives(d, "label")) == _old_tag(p)
    words = _old_key_parts(p)
    key = legacy_trial_key(p)
    assert all(f"-{w}-" in f"{key}-" for w in words), (key, words)
    assert _old_tag(p) in row_label(p)


# ------------------------------------------------------- every row the command lines take
WORDS = ("skip1", "skip5", "skip10", "adaptive", "boxqp", "central", "costdofs", "mureset")
FLAGS = list(itertools.product(("forward", "central"), (1, 5), (None, "adaptive"),
                               (False, True)))


def _accepted_rows():
    for name in TABLE1_ROWS:
        for k in range(4):
            for mods in itertools.combinations(WORDS, k):
                spec = "+".join((name, *mods))
                try:
                    yield spec, parse_row(spec)
                except ValueError:
                    continue               # two keypoint variants: refused, runs nothing


def test_every_accepted_row_spells_todays_params_key_and_label():
    """The command lines' path (flags -> Derivatives, a row's variants replace some of its
    fields) gives the params the old field mapping gave, and today's key and label."""
    seen = 0
    for spec, row in _accepted_rows():
        for fd, fd_skip, keypoints, box_qp in FLAGS:
            kp = keypoints or ("skip" if fd_skip > 1 else "every")
            skip = fd_skip if kp == "skip" else 1
            flags = Derivatives(fd, kp, skip, box_qp)
            new = replace(flags, **row.variants).fields()
            old = {**_old_fields(fd, kp, skip, box_qp)}
            over = dict(row.variants)
            if "fd" in over:
                old.update({k: v for k, v in _old_fields(over["fd"], "every", 1, False).items()
                            if k.startswith("fd_") and k != "fd_skip"})
            old.update({k: v for k, v in over.items() if k in ("keypoints", "fd_skip",
                                                                "box_qp")})
            assert new == old, (spec, fd, fd_skip, keypoints, box_qp)
            settings_ = SVRMPCSettings.paper("clutter").with_params(
                method=row.method, theta=row.theta, rho=float(row.rho), slowdown=1.0, **new,
                **row.fixes)
            p = trial_params(settings_, 3)
            assert {k: p[k] for k in old} == old
            assert settings_.derivatives == replace(flags, **row.variants)
            _check_against_old(p)
            seen += 1
    assert seen > 9 * len(FLAGS) * 20


# --------------------------------------------------------------- every committed trial
def _committed():
    for path in sorted(RUNS.glob("*/trials/pack.jsonl*")):
        opener = gzip.open if path.suffix == ".gz" else open
        with opener(path, "rt") as lines:
            yield from (json.loads(line) for line in lines if line.strip())
    for path in sorted(RUNS.glob("*/trials/*.json")):
        yield json.loads(path.read_text())


def test_committed_trial_keys_are_their_legacy_keys_and_their_new_names_unique():
    """Every committed MPC trial's key is ``legacy_trial_key`` of its params (the name a sweep
    finds it under, ``Schema.aliases``), the derivative words spelled by ``spell_derivatives``,
    and its label the old label; and the names of the one identity (``trial_key``) tell every
    two different committed trials apart and take no committed trial's key."""
    n, names, keys = 0, {}, set()
    for record in _committed():
        p = record["params"]
        if "rho" not in p:
            continue                                   # a pick-and-place trial
        assert legacy_trial_key(p) == record["key"]
        _check_against_old(p)
        names.setdefault(trial_key(p), set()).add(record["key"])
        keys.add(record["key"])
        n += 1
    assert n > 1000, n
    assert all(len(old) == 1 for old in names.values()), \
        [(k, v) for k, v in names.items() if len(v) > 1][:3]
    assert not names.keys() & keys


# --------------------------------------------------------------------- round trips
DERIVATIVES = st.builds(
    lambda fd, kp, skip, box_qp, eps: Derivatives(fd, kp, skip if kp == "skip" else 1, box_qp,
                                                  eps),
    st.sampled_from(["forward", "central"]), st.sampled_from(["every", "skip", "adaptive"]),
    st.integers(1, 40), st.booleans(), st.sampled_from([None, 1e-3, 1e-6, 1e-4, 3e-5]))


@settings(max_examples=200, deadline=None)
@given(DERIVATIVES)
def test_one_value_survives_fields_settings_and_ilqr(d):
    """Derivatives -> flat fields -> settings -> ILQRConfig and back is the same value, and
    what ILQR runs is the named step unless fd_eps overrides it."""
    assert Derivatives.from_fields(d.fields()) == d
    s = SVRMPCSettings().with_params(slowdown=3.0, **d.fields())
    assert s.derivatives == d and s.ilqr.derivatives == d
    assert s == replace(SVRMPCSettings(), derivatives=d).with_params(slowdown=3.0)
    assert isinstance(s.ilqr, ILQRConfig)
    named = 1e-6 if d.fd == "central" else 1e-3
    assert d.fd_config.eps == (named if d.fd_eps is None else d.fd_eps)
    assert d.fd_config.centered == (d.fd == "central")
    _check_against_old(trial_params(s, 0))
    if d.fd_eps is None:                            # a row can name it: the words parse back
        assert replace(Derivatives(), **parse_variants(spell_derivatives(d, "row"))) == d
    else:
        with pytest.raises(ValueError, match="no row variant names finite differences"):
            spell_derivatives(d, "row")


def test_fd_eps_at_the_named_step_is_the_named_difference():
    assert Derivatives("central", fd_eps=1e-6) == Derivatives("central")
    assert Derivatives(fd_eps=1e-6).fields()["fd_eps"] == 1e-6
    with pytest.raises(ValueError, match="FDConfig.eps must be >="):
        Derivatives(fd_eps=1e-15)
    with pytest.raises(ValueError, match="fd_skip must be 1 with keypoints 'every'"):
        SVRMPCSettings().with_params(fd_skip=5)
