"""The one trial identity (``dopt.lab.identity``): a name is its label, its seed and a hash of
the settings that differ from a fixed reference. Property tests over nested settings drawn by
generators of these tests' own, and the hash checked against ``hashlib`` of the canonical JSON
written out by hand."""

import hashlib
from dataclasses import dataclass, field

import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from dopt.lab.identity import canonical, changed_settings, field_defaults, trial_name

NAMES = st.text(alphabet="abcdefghijklmnopqrstuvwxyz_", min_size=1, max_size=6)
LEAVES = (st.none() | st.booleans() | st.integers(-10**6, 10**6)
          | st.floats(allow_nan=False, allow_infinity=False, width=32)
          | st.text(max_size=5) | st.lists(st.integers(-5, 5), max_size=3))
SETTINGS = st.recursive(LEAVES, lambda inner: st.dictionaries(NAMES, inner, min_size=1,
                                                               max_size=4), max_leaves=12)
DICTS = st.dictionaries(NAMES, SETTINGS, max_size=5)


def leaves(d, prefix=""):
    """{dotted name: leaf} of a nested dict (the tests' own flattening)."""
    out = {}
    for k, v in d.items():
        if isinstance(v, dict) and v:
            out.update(leaves(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def set_leaf(d, dotted, value):
    """A copy of ``d`` with the leaf at ``dotted`` replaced."""
    head, _, rest = dotted.partition(".")
    out = dict(d)
    out[head] = value if not rest else set_leaf(d[head], rest, value)
    return out


def other_than(value):
    """A value that no canonical rule can take for ``value``."""
    return "a different value" if value != "a different value" else 7


@given(DICTS, DICTS, NAMES, SETTINGS)
def test_a_setting_added_at_its_default_never_changes_the_name(values, defaults, name, v):
    assume(name not in values and name not in defaults)
    before = trial_name("m", 3, values, defaults)
    assert trial_name("m", 3, {**values, name: v}, {**defaults, name: v}) == before
    # and older values that lack it name the same trial as newer ones that hold its default
    assert trial_name("m", 3, values, {**defaults, name: v}) == before


@given(DICTS, DICTS, st.data())
def test_any_change_of_a_leaf_that_is_not_at_its_default_changes_the_name(values, defaults,
                                                                           data):
    changed = changed_settings(values, defaults)
    assume(changed)
    dotted = data.draw(st.sampled_from(sorted(changed)))
    edited = set_leaf(values, dotted, other_than(leaves(values)[dotted]))
    assert trial_name("m", 0, edited, defaults) != trial_name("m", 0, values, defaults)


@given(DICTS, DICTS, st.randoms(use_true_random=False))
def test_key_order_does_not_matter(values, defaults, rnd):
    def shuffled(d):
        items = list(d.items())
        rnd.shuffle(items)
        return {k: shuffled(v) if isinstance(v, dict) else v for k, v in items}
    assert (trial_name("m", 1, shuffled(values), shuffled(defaults))
            == trial_name("m", 1, values, defaults))


@given(st.integers(-10**9, 10**9), DICTS)
def test_an_integral_float_is_its_int_and_a_tuple_its_list(n, defaults):
    assert trial_name("m", 0, {"a": n, "b": (n, 2)}, defaults) == \
        trial_name("m", 0, {"a": float(n), "b": [float(n), 2.0]}, defaults)
    assert changed_settings({"a": float(n)}, {"a": n}) == {}


def test_a_bool_stays_a_bool():
    assert changed_settings({"a": True}, {"a": 1}) == {"a": True}
    assert changed_settings({"a": 0}, {"a": False}) == {"a": 0}
    assert canonical(True) is True and canonical(2.5) == 2.5 and canonical((1.0,)) == [1]


def test_the_name_hashes_the_canonical_json_of_the_changed_settings():
    """Checked against hashlib over JSON written out here: sorted keys, no spaces, dotted
    names of the nested leaves that differ from the reference (a leaf the reference lacks is
    kept; a name the values lack is at its default)."""
    values = {"cem": {"population": 32.0, "horizon": 2}, "goal": "diagonal", "x": (1, 2.5)}
    defaults = {"cem": {"population": 32, "horizon": 3}, "side": 0.3}
    text = '{"cem.horizon":2,"goal":"diagonal","x":[1,2.5]}'
    digest = hashlib.sha1(text.encode()).hexdigest()[:8]
    assert trial_name("simple", 4, values, defaults) == f"simple-seed4-{digest}"
    assert trial_name("simple", 4, {}, defaults) == \
        f"simple-seed4-{hashlib.sha1(b'{}').hexdigest()[:8]}"


@pytest.mark.parametrize("label, seed, error, words", [
    ("", 0, ValueError, "label"), ("a/b", 0, ValueError, "label"), (".x", 0, ValueError, "label"),
    (3, 0, TypeError, "label"), ("m", -1, ValueError, "seed"), ("m", True, TypeError, "seed"),
    ("m", 1.0, TypeError, "seed"), ("m", "0", TypeError, "seed")])
def test_bad_labels_and_seeds_are_named(label, seed, error, words):
    with pytest.raises(error, match=words):
        trial_name(label, seed, {}, {})


def test_bad_settings_are_named():
    with pytest.raises(TypeError, match="values must be a dict"):
        trial_name("m", 0, [1], {})
    with pytest.raises(TypeError, match=r"cem\.when"):
        trial_name("m", 0, {"cem": {"when": object()}}, {})
    with pytest.raises(ValueError, match="'a.b'"):
        changed_settings({"a.b": 1}, {})
    with pytest.raises(TypeError, match="setting names must be str"):
        changed_settings({}, {1: 2})


def test_field_defaults_are_the_class_defaults_only():
    @dataclass(frozen=True)
    class Inner:
        k: int = 2
        t: tuple = (1, 2)

    @dataclass(frozen=True)
    class Outer:
        required: str
        inner: Inner = Inner()
        items: list = field(default_factory=lambda: [3])
        off: float | None = None

    assert field_defaults(Outer) == {"inner": {"k": 2, "t": (1, 2)}, "items": [3],
                                     "off": None}
    with pytest.raises(TypeError, match="dataclass class"):
        field_defaults(Outer("x"))
