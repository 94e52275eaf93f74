"""What each marker and shade of a view means, and the floor's scale: one legend for the
browser panel (``legend_html``) and the PNG still (``dopt.view.still``), built from the
episode itself, so a new marker or ghost is in both without a word elsewhere.

``legend_items(ep)`` lists the cloth's two faces (or the rope, the soft body), the goal ghost,
the goal regions, each set of markers, the shade of the SVR active set and a blow-up's marked
body; ``floor_items(length)`` the floor's grid and scale bar. ``floor_height`` and
``nice_length`` place and size that grid and bar. No viser, no PIL here.

Shapes: F frames, P points.
"""

from __future__ import annotations

import html
from dataclasses import dataclass

import mujoco
import numpy as np

from dopt.view.mjscene import MARK_COLOUR, SHADE_HIGH, SHADE_LOW, underside_colour

#: what a legend swatch looks like
KINDS = ("dot", "line", "patch", "ramp", "ring")
#: the floor grid's colour and the scale bar's
GRID_COLOUR, BAR_COLOUR = (150, 150, 150), (20, 20, 20)


@dataclass(frozen=True)
class LegendItem:
    """One line of the legend: its text, an RGB colour (0-255), the swatch's kind (``KINDS``)
    and, for a "ramp", the colour it ends at."""

    name: str
    colour: tuple[int, int, int]
    kind: str = "dot"
    end: tuple[int, int, int] | None = None

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {self.kind!r}")


def _rgb(rgba01) -> tuple[int, int, int]:
    return tuple(int(round(255 * c)) for c in np.asarray(rgba01, dtype=float)[:3])


def legend_items(ep, browser: bool = True) -> list[LegendItem]:
    """The legend of an episode (``dopt.view.episode.Episode``): its deformables, goal ghost,
    regions, markers, shade and marked body, in that order; as the browser draws them (a
    cloth's two faces in two colours, the ghost as wire) or as a still does (``browser``
    False: MuJoCo's cloth in one colour, the ghost as dots)."""
    m = ep.model
    items: list[LegendItem] = []
    for f in range(m.nflex):
        own, dim = _rgb(m.flex_rgba[f]), int(m.flex_dim[f])
        if dim == 2 and not browser:
            items.append(LegendItem("cloth", own, "patch"))
        elif dim == 2:
            items += [LegendItem("cloth, top face", own, "patch"),
                      LegendItem("cloth, underside", underside_colour(own), "patch")]
        else:
            items.append(LegendItem("rope" if dim == 1 else "soft body", own,
                                    "line" if dim == 1 else "patch"))
    if ep.ghost is not None:
        items.append(LegendItem(f"{ep.ghost.name} (the goal, as {'wire' if browser else 'dots'})",
                                ep.ghost.colour, "line" if browser else "dot"))
    items += [LegendItem(r.name, r.colour, "patch") for r in ep.regions]
    items += [LegendItem(mk.name, mk.colour, "dot") for mk in ep.markers]
    if ep.shade is not None:
        items.append(LegendItem("object shade: share of its DoFs in C (none .. all)",
                                tuple(int(c) for c in SHADE_LOW), "ramp",
                                tuple(int(c) for c in SHADE_HIGH)))
    if ep.marked_body is not None:
        items.append(LegendItem("the body that blew up", MARK_COLOUR, "ring"))
    return items


def floor_items(length: float) -> list[LegendItem]:
    """The floor's grid (cells of ``length`` m) and its scale bar."""
    text = length_text(length)
    return [LegendItem(f"floor grid: {text} cells", GRID_COLOUR, "line"),
            LegendItem(f"scale bar: {text}", BAR_COLOUR, "line")]


def nice_length(extent: float) -> float:
    """A round length (1, 2 or 5 times a power of ten, m) near a quarter of ``extent`` (m),
    for the grid's cells and the scale bar."""
    target = max(float(extent), 1e-3) / 4
    power = 10.0 ** np.floor(np.log10(target))
    return float(max((k * power for k in (1, 2, 5) if k * power <= target), default=power))


def length_text(length: float) -> str:
    """"10 cm", "5 mm", "1 m": a length (m) in the unit that reads best."""
    if length >= 1:
        return f"{length:g} m"
    if length >= 0.01:
        return f"{round(length * 100, 3):g} cm"
    return f"{round(length * 1000, 3):g} mm"


def floor_height(model: mujoco.MjModel, points: np.ndarray) -> float:
    """The z (m) of the floor under ``points`` (P, 3): the highest upward plane of the world
    body at or below their lowest point, else that lowest point."""
    low = float(np.min(points[:, 2])) if len(points) else 0.0
    heights = []
    for g in range(model.ngeom):
        if int(model.geom_type[g]) != mujoco.mjtGeom.mjGEOM_PLANE or model.geom_bodyid[g]:
            continue
        rot = np.empty(9)
        mujoco.mju_quat2Mat(rot, model.geom_quat[g])
        z = float(model.geom_pos[g][2])
        if rot[8] > 0.99 and z <= low + 1e-6:                  # the plane's normal is +z
            heights.append(z)
    return max(heights) if heights else low


def _swatch_css(item: LegendItem) -> str:
    rgb = "rgb({},{},{})".format(*item.colour)
    if item.kind == "dot":
        return f"width:10px;height:10px;border-radius:50%;background:{rgb}"
    if item.kind == "ring":
        return f"width:8px;height:8px;border-radius:50%;border:2px solid {rgb}"
    if item.kind == "line":
        return f"width:18px;height:3px;background:{rgb}"
    if item.kind == "ramp":
        end = "rgb({},{},{})".format(*item.end)
        return f"width:18px;height:10px;background:linear-gradient(90deg,{rgb},{end})"
    return f"width:12px;height:10px;background:{rgb}"


def legend_html(items) -> str:
    """The legend as HTML for the browser panel: a swatch and a name per line."""
    rows = "".join(
        f'<div style="display:flex;align-items:center;gap:6px;margin:1px 0">'
        f'<span style="display:inline-block;flex:none;{_swatch_css(i)}"></span>'
        f"<span>{html.escape(i.name)}</span></div>" for i in items)
    return (f'<div class="dopt-legend" style="font-size:0.8em;line-height:1.3">'
            f"<b>legend</b>{rows}</div>")
