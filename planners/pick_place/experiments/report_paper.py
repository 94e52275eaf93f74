"""What the key-particle paper's report modules share: the paper's name, Fig. 7's panels and
method labels (the library's own, ``planners.pick_place.LABELS``), and the scaling studies'
trend tests grouped into Holm families.
"""

from __future__ import annotations

from dopt.lab.multiple import holm_slopes
from dopt.lab.report.base import Result, num
from planners.pick_place import GOAL_NAMES, LABELS

#: the paper, as the pages, the catalogue and the map name it
KP = "key particles"
#: Fig. 7 panel of each (task, goal) of the key-particle paper ("(c) cloth diagonal fold"),
#: read from the one goal-name table
FIG7_PANELS = {(g.task, g.goal): g.label for g in GOAL_NAMES if g.panel is not None}


def _label(method: str) -> str:
    return LABELS.get(method, method)


def _in_label_order(methods) -> list[str]:
    """The distinct ``methods`` in the figures' order (``LABELS``), unknown ones after,
    sorted."""
    seen = set(methods)
    known = [m for m in LABELS if m in seen]
    return known + sorted(seen - set(known))


def _methods_in_order(results: list[Result]) -> list[str]:
    return _in_label_order(m for r in results for m in r.data["methods"])


def _panel_of(task, goal) -> str:
    return FIG7_PANELS.get((task, goal), f"{task} {goal}")


def _panel_rank(task, goal) -> int:
    """The place of (task, goal) in the paper's Fig. 7 (``FIG7_PANELS``); unknown ones last."""
    order = list(FIG7_PANELS)
    return order.index((task, goal)) if (task, goal) in order else len(order)


def _panel(r: Result) -> str:
    return _panel_of(r.data.get("task"), r.data.get("goal"))


# ------------------------------------------------------------- the scaling studies
def scaling_key(r) -> str:
    """A scaling file's name among the others: its fold, and "at fixed spacing" for a sweep
    that grows the sheet (``fig7_scaling.py --mode size``; a file without a mode refined the
    fixed sheet)."""
    return r.data.get("goal") + (" at fixed spacing" if r.data.get("mode") == "size" else "")


def family_note(f: dict | None) -> str:
    """The verdict of every fold's trend tests together (a family of ``trend_families``), as a
    section's table caption ends: '; Holm p over the M tests of the F folds P: **verdict**';
    '' without one."""
    return (f"; Holm p over the {f['m']} tests of the {f['folds']} folds "
            f"{num(f['p_holm'], 3)}: **{f['verdict']}**") if f else ""


def trend_families(files: dict, group=lambda r: "") -> dict:
    """{(key, test): Holm over the trend tests of the files ``files`` ({key: file}, each a
    summary with "trend": ``planners.pick_place.scaling.scaling_summary``'s) of one ``group``
    together, ``holm_slopes``, with "folds": how many files}; a group with one file has no
    family."""
    family = {}
    for g in {group(r) for r in files.values()}:
        tests = {k: r.data["trend"] for k, r in files.items() if group(r) == g}
        if len(tests) > 1:
            family.update({k: {**v, "folds": len(tests)} for k, v in holm_slopes(tests).items()})
    return family


def n_range(r, counts: str) -> str:
    """A scaling or drag-encoding file's counts N (its ``counts`` field) as 'N lo-hi'."""
    return f"N {min(r.data[counts])}-{max(r.data[counts])}"


def scaling_families(results: list) -> tuple[dict, dict]:
    """({scaling_key: file} of the scaling files, {(key, test): Holm over the trend tests of
    the files of one mode together, ``trend_families``})."""
    files = {scaling_key(r): r for r in results if r.kind == "fig7_scaling"}
    return files, trend_families(files, lambda r: r.data.get("mode", "resolution"))


# ------------------------------------------------------- the drag encoding's sweeps
def encoding_key(r) -> str:
    """A drag-encoding file's name among the others: its fold, and "final cost" for a run
    that scores a plan after the whole of it (``fig7_encoding.py --cost final``; the
    authors' best-over-trajectory cost otherwise)."""
    drags = [s.get("drag") or {} for s in (r.data.get("settings") or {}).values()]
    final = any(d.get("best_over_trajectory") is False for d in drags)
    return str(r.data.get("goal")) + (", final cost" if final else "")


def encoding_families(results: list) -> tuple[dict, dict]:
    """({encoding_key: file} of the drag-encoding files but quick runs, {(key, test): Holm
    over all their trend tests together, ``trend_families``})."""
    files = {encoding_key(r): r for r in results if r.kind == "fig7_encoding" and not r.quick}
    return files, trend_families(files)
