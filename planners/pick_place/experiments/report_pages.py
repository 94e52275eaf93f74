"""The key-particle paper's page (docs/KEY-PARTICLES.md, ``dopt.lab.report.pages``): its
pictures and its tables beside the paper's."""

from __future__ import annotations

from pathlib import Path

from dopt.lab.report.base import Result, mm, pm, source, table
from dopt.lab.report.pages import Page
from planners.pick_place.experiments.report_fig7 import _departs, fig7_cell
from planners.pick_place.experiments.report_paper import FIG7_PANELS, KP, _label


def kp_tables(results: list[Result], page: Path) -> list[str]:
    """The paper's key-particle counts beside ours, and Fig. 7 under the paper's protocol."""
    lines = []
    keys = [r for r in results if r.kind == "key_particles" and not r.quick]
    if keys:
        r = keys[-1]
        tasks, paper = r.data.get("tasks") or {}, r.data.get("paper") or {}
        rows = [[goal.replace("_", " "), str((paper.get(goal) or {}).get("keys", "-")),
                 str(e.get("n_keys")), str((paper.get(goal) or {}).get("triangles", "-")),
                 str(e.get("n_elements")) if goal.startswith("cloth") else "-"]
                for goal, e in tasks.items()]
        lines += ["### Key particles per goal (Fig. 4)", "",
                  *table(["goal", "paper keys", "our keys", "paper triangles",
                          "our triangles"], rows), "", f"Source: {source(r, page)}.", ""]
    fig7 = sorted((r for r in results if r.kind == "fig7" and not r.quick and not _departs(r)
                   and r.data.get("protocol") == "paper"),
                  key=lambda r: list(FIG7_PANELS).index((r.data.get("task"), r.data.get("goal")))
                  if (r.data.get("task"), r.data.get("goal")) in FIG7_PANELS else 99)
    if fig7:
        methods = ("simple", "original", "random", "scripted")
        rows = [[FIG7_PANELS.get((r.data.get("task"), r.data.get("goal")), r.name),
                 *(fig7_cell(r.data["methods"].get(m)) for m in methods),
                 str(max((e.get("n") or 0) for e in r.data["methods"].values())),
                 source(r, page)] for r in fig7]
        lines += ["### Fig. 7: final cost under the paper's protocol", "",
                  "The paper plots cost curves; these are the final mean particle distances to "
                  "the goal (mm, mean ± 95 % interval over the seeds).", "",
                  *table(["panel", *(_label(m) for m in methods), "seeds", "source"], rows), ""]
    panda = [r for r in results if r.kind == "panda_execute" and not r.quick]
    if panda:
        r = panda[-1]
        rows = [[goal, pm(mm(e["picker_final_cost_mean"]), mm(e["picker_final_cost_ci95"])),
                 pm(mm(e["panda_final_cost_mean"]), mm(e["panda_final_cost_ci95"])),
                 str(e["n"])] for goal, e in r.data["goals"].items()]
        lines += ["### Sec. IV-D: the plans on a Panda (simulated)", "",
                  *table(["goal", "picker final cost (mm)", "Panda final cost (mm)", "seeds"],
                         rows), "", f"Source: {source(r, page)}.", ""]
    return lines


PAGE = Page(KP, "KEY-PARTICLES.md", "Key particles: the paper's claims beside our runs",
            "S. Wang, R. Papallas, M. Leonetti, M. Dogar, *Goal-Conditioned Action Space "
            "Reduction for Deformable Object Manipulation*, ICRA 2023",
            (("fold-diagonal.png", "CEM(Simple) folds the cloth along its diagonal (goal "
                                   "left, result right)"),
             ("panda-diagonal.png", "A Panda executes the diagonal fold's plan")),
            {"fig7_scaling": lambda d: f"Sec. V, the {d.get('goal')} fold: final cost and "
                                       "the gaps to CEM(Simple) against the particle count, "
                                       "95 % intervals",
             "fig7_encoding": lambda d: f"Sec. V under the authors' drag encoding, the "
                                        f"{d.get('goal')} fold: final cost and the gaps to "
                                        "CEM(Simple) against the candidate count N, 95 % "
                                        "intervals"},
            kp_tables)
