"""Project a noisy folded-cloth goal onto its flat panels (goal denoising for the cloth branch).

Shape letters: N particles, F faces, P panels, k neighbours.

A folded cloth is piecewise rigid: each flat panel of the goal is its region of the flat rest
sheet moved by one rotation and translation, and creases join the panels. Quadric edge-collapse
decimation cannot see that through noise: at 0.05 mm per coordinate its collapse order already
changes, and from 0.5 mm Alg. 1 does not converge (docs/DESIGN-NOTES.md, "Key particles").
This module recovers the panels and replaces every particle a panel explains by the panel's
prediction, so that the noise left is that of one rigid fit over hundreds of particles.

1. Local rigid fits: every particle's goal = R rest + t (Kabsch) over the neighbourhood that
   fits it best among its ``neighbours`` nearest rest neighbours and the four quadrants of the
   rest sheet around it (:func:`local_rotations`): a straight crease leaves a quadrant wholly on
   one side, so the edge rows of a panel three particles wide keep their panel's rotation.
2. Panels: connected components of the mesh edges whose two local rotations agree within
   ``angle_deg``; components too small or too narrow (a crease row) are dropped.
3. One rigid fit per panel (trimmed: residuals over 3 medians are refitted without). The
   median distance of a particle from its best panel's prediction estimates the noise (about
   1.5 sigma for Gaussian noise of sigma per coordinate; 0 on an exact fold). The local fits'
   residuals do not: where panels are only a few particles wide (12 x 12 underneath fold) many
   neighbourhoods straddle a crease.
4. Labels: each particle goes to the panel that predicts it best, then the boundaries between
   panels are made straight lines of the rest sheet by a multinomial logistic regression on the
   rest sheet's coordinates, fitted to the particles one panel explains clearly better than
   the others (the middle row of a crease rounded symmetrically about its line is as far from
   both panels, and its labels would only tilt the line). A fold's crease is a straight line
   of the rest sheet; per-particle labels are not: particles on the crease are equally far from
   both panels, noise picks a side for each, and the resulting saw-tooth crease costs
   decimation extra vertices. The particles within ``crease_width`` spacings of a line all go
   to whichever of its two panels explains them better (:func:`panel_weights`): a crease
   through a row of particles is one straight step, where a linear blend of the two panels'
   predictions would pull that row half-way between the layers into a one-spacing fold of its
   own. On 800 goals of tests/deformables/test_key_particles_properties.py (seeds 16-19), a
   blend with every label in the fit loses 2 counts, fits over the nearest neighbours alone
   1, this module none; the library's 336 goals of 12-40 per side (4 folds, 4
   triangulations, 3 seeds) keep every count at 1 and at 2 mm of noise under all three.
5. Every particle whose prediction lies within ``tolerance`` (default: a layer gap plus
   3 sqrt(3) times the noise estimate) moves to it; the others (a wrinkle, a crumpled region)
   keep their measured position.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from dopt.validation import check_int, check_real

from .mesh import edges
from .validation import check_faces, check_numeric, check_positions

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class PanelFit:
    """Outcome of :func:`project_on_panels`.

    Attributes:
        positions: ``(N, 3)`` projected goal (measured positions where no panel explains one).
        labels: ``(N,)`` panel of each projected particle, -1 for the others.
        rotations: ``(P, 3, 3)`` and ``translations`` ``(P, 3)``: panel p maps rest x to
            ``rotations[p] @ x + translations[p]``.
        noise: the estimated noise, metres: the median distance of a particle from its best
            panel's prediction (the median local-fit residual when no panel is found).
        projected: ``(N,)`` bool, the particles moved onto their panel.
    """

    positions: np.ndarray
    labels: np.ndarray
    rotations: np.ndarray
    translations: np.ndarray
    noise: float
    projected: np.ndarray

    @property
    def n_panels(self) -> int:
        return len(self.rotations)


def rigid_fit(rest: np.ndarray, goal: np.ndarray,
              weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least-squares rotations and translations, goal ~ R rest + t, for B point sets at once.

    scipy's ``Rotation.align_vectors`` solves the same problem one set per call; here every
    particle's neighbourhood is one set, so the Kabsch SVD runs batched.

    Args:
        rest, goal: ``(B, k, 3)`` corresponding points.
        weights: ``(B, k)`` non-negative weight of each point (each set's must sum to more
            than 0); ``None``: all 1. A set of varying size is a padded set with weights 0.

    Returns:
        ``R`` ``(B, 3, 3)`` proper rotations, ``t`` ``(B, 3)``, weighted RMS residual ``(B,)``.

    Raises:
        TypeError / ValueError: non-numeric arrays, shapes other than the same ``(B, k, 3)``
            with B, k >= 1, or NaN/inf entries; weights not ``(B, k)``, negative, or all 0 in
            a set.
    """
    rest = np.asarray(check_numeric(rest, "rest"), dtype=float)
    goal = np.asarray(check_numeric(goal, "goal"), dtype=float)
    if rest.ndim != 3 or rest.shape[2] != 3 or rest.shape[0] < 1 or rest.shape[1] < 1:
        raise ValueError(f"rest must have shape (B, k, 3) with B, k >= 1, got {rest.shape}")
    if goal.shape != rest.shape:
        raise ValueError(f"goal must have the shape of rest {rest.shape}, got {goal.shape}")
    for name, arr in (("rest", rest), ("goal", goal)):
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} contains NaN/inf")
    if weights is None:
        w = np.ones(rest.shape[:2])
    else:
        w = np.asarray(check_numeric(weights, "weights"), dtype=float)
        if w.shape != rest.shape[:2]:
            raise ValueError(f"weights must have shape {rest.shape[:2]}, got {w.shape}")
        if not np.all(np.isfinite(w)) or np.any(w < 0) or np.any(w.sum(axis=1) <= 0):
            raise ValueError("weights must be finite, >= 0 and not all 0 in a set")
    w = w / w.sum(axis=1, keepdims=True)
    rest_c = np.einsum("bk,bki->bi", w, rest)
    goal_c = np.einsum("bk,bki->bi", w, goal)
    # batched matmuls: three-operand einsums do not reach BLAS and were most of this function
    cov = np.matmul(((rest - rest_c[:, None]) * w[..., None]).transpose(0, 2, 1),
                    goal - goal_c[:, None])                                   # (B, 3, 3)
    u, _, vt = np.linalg.svd(cov)
    det = np.linalg.det(u) * np.linalg.det(vt)                   # det(V U^T)
    d = np.ones(rest.shape[:1] + (3,))
    d[:, 2] = np.where(det < 0, -1.0, 1.0)                       # no reflections
    rot = np.matmul(vt.transpose(0, 2, 1) * d[:, None, :], u.transpose(0, 2, 1))  # V diag(d) U^T
    shift = goal_c - np.einsum("bij,bj->bi", rot, rest_c)
    residual = np.matmul(rest, rot.transpose(0, 2, 1)) + shift[:, None] - goal
    return rot, shift, np.sqrt(np.einsum("bk,bk->b", w, (residual ** 2).sum(axis=2)))


def local_rotations(rest: np.ndarray, goal: np.ndarray, spacing: float,
                    neighbours: int = 9) -> tuple[np.ndarray, np.ndarray]:
    """Every particle's local rigid fit, from the neighbourhood that fits it best.

    The candidates are the ``neighbours`` nearest rest neighbours (centred on the particle)
    and, where that fit's residual exceeds three times the residual of the best-fitting tenth
    of the particles (near a crease), the four quadrants of the rest sheet around it (its
    rest neighbours within 2.3 spacings whose offsets along the sheet's two principal axes
    have given signs; quadrants of fewer than 4 particles, or one row, are skipped). A
    straight crease through or near a particle leaves at least one quadrant wholly on one
    side, so a particle on a panel's edge row gets its panel's rotation, not a blend of two
    panels' (a 3-row panel of a 12 x 12 underneath fold would otherwise keep only its middle
    row).

    Returns:
        rotations ``(N, 3, 3)`` and the RMS residual ``(N,)`` of the chosen fits.
    """
    n = len(rest)
    tree = cKDTree(rest)
    _, near = tree.query(rest, min(neighbours, n))
    best_rot, _, best_rms = rigid_fit(rest[near], goal[near])
    # only particles whose centred fit is off (near a crease) try the quadrants; the fits of
    # the best tenth are inside panels even where panels are three rows wide
    floor = 3.0 * float(np.quantile(best_rms, 0.1))
    unsure = np.flatnonzero(best_rms > max(floor, 1e-9 * spacing))
    if len(unsure) == 0:
        return best_rot, best_rms
    pool = min(25, n)
    dist, near = tree.query(rest[unsure], pool)
    centred = rest - rest.mean(axis=0)
    plane = np.linalg.svd(centred, full_matrices=False)[2][:2]                    # (2, 3)
    offset = (rest[near] - rest[unsure, None]) @ plane.T                           # (U, k, 2)
    inside = dist <= 2.3 * spacing
    tol = 1e-6 * spacing
    for sx in (-1.0, 1.0):
        for sy in (-1.0, 1.0):
            member = inside & (sx * offset[..., 0] >= -tol) & (sy * offset[..., 1] >= -tol)
            count = member.sum(axis=1)
            spread_x = np.where(member, offset[..., 0], np.nan)
            spread_y = np.where(member, offset[..., 1], np.nan)
            with np.errstate(invalid="ignore"):
                flat = ((np.nanmax(spread_x, axis=1) - np.nanmin(spread_x, axis=1) < 0.5 * spacing)
                        | (np.nanmax(spread_y, axis=1) - np.nanmin(spread_y, axis=1)
                           < 0.5 * spacing))
            usable = (count >= 4) & ~flat
            if not usable.any():
                continue
            rows = np.flatnonzero(usable)
            rot, _, rms = rigid_fit(rest[near[rows]], goal[near[rows]],
                                    member[rows].astype(float))
            target = unsure[rows]
            better = rms < best_rms[target]
            best_rot[target[better]] = rot[better]
            best_rms[target[better]] = rms[better]
    return best_rot, best_rms


def _turn_cosine(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cosine of the angle of the rotation from ``a`` to ``b`` (each ``(..., 3, 3)``),
    (tr(a^T b) - 1) / 2, shape ``(...)``."""
    return (np.einsum("...ij,...ij->...", a, b) - 1.0) / 2.0


def _panels(rest: np.ndarray, pairs: np.ndarray, rot: np.ndarray, spacing: float,
            angle_deg: float, min_particles: int, min_width: float) -> list[np.ndarray]:
    """Components of the edge graph whose local rotations agree; each ``(n_p,)`` indices."""
    n = len(rest)
    agree = pairs[_turn_cosine(rot[pairs[:, 0]], rot[pairs[:, 1]]) > np.cos(np.radians(angle_deg))]
    graph = coo_matrix((np.ones(len(agree)), (agree[:, 0], agree[:, 1])), shape=(n, n))
    _, component = connected_components(graph, directed=False)
    panels = []
    for members in np.split(np.argsort(component, kind="stable"),
                            np.cumsum(np.bincount(component))[:-1]):
        if len(members) < min_particles:
            continue
        spread = np.linalg.svd(rest[members] - rest[members].mean(axis=0), compute_uv=False)
        if spread[1] / np.sqrt(len(members)) < min_width * spacing:       # a crease row
            continue
        panels.append(members)
    return panels


def _panel_transform(rest: np.ndarray, goal: np.ndarray, members: np.ndarray,
                     rounds: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """One panel's rigid transform, refitted without members over 3 median residuals."""
    inliers = members
    for _ in range(rounds):
        rot, shift, _ = rigid_fit(rest[None, inliers], goal[None, inliers])
        err = np.linalg.norm(rest[members] @ rot[0].T + shift[0] - goal[members], axis=1)
        keep = members[err <= 3.0 * np.median(err)]
        if len(keep) < 3 or np.array_equal(keep, inliers):
            break
        inliers = keep
    return rot[0], shift[0]


def _fit_panels(rest: np.ndarray, goal: np.ndarray,
                members: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Each panel's rigid transform (:func:`_panel_transform`): rotations ``(P, 3, 3)`` and
    translations ``(P, 3)``."""
    fits = [_panel_transform(rest, goal, m) for m in members]
    return np.stack([r for r, _ in fits]), np.stack([t for _, t in fits])


def _merge_panels(rest: np.ndarray, goal: np.ndarray, pairs: np.ndarray,
                  members: list[np.ndarray], merge_deg: float
                  ) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """Join neighbouring panels whose rigid fits turn by less than ``merge_deg`` from each
    other, refit, and repeat until none do. Two panels are neighbours where a mesh edge joins
    particles the two explain best. A fold turns one panel against the next by 90-180 degrees;
    a wrinkle or a sag splits a panel into pieces that turn by tens of degrees. Returns the
    members and their fits (:func:`_fit_panels`)."""
    rot, shift = _fit_panels(rest, goal, members)
    while len(members) > 1:
        predicted = np.einsum("pij,nj->pni", rot, rest) + shift[:, None]
        labels = np.linalg.norm(predicted - goal[None], axis=2).argmin(axis=0)
        a, b = labels[pairs[:, 0]], labels[pairs[:, 1]]
        touching = sorted({(int(x), int(y)) for x, y in zip(np.minimum(a, b), np.maximum(a, b),
                                                             strict=True) if x != y})
        if not touching:
            break
        p_idx, q_idx = np.array(touching).T
        turns = np.degrees(np.arccos(np.clip(_turn_cosine(rot[p_idx], rot[q_idx]), -1.0, 1.0)))
        closest = int(np.argmin(turns))
        if turns[closest] >= merge_deg:
            break
        p, q = touching[closest]
        logger.info("panel projection: panels of %d and %d particles turn by %.0f deg; joined",
                    len(members[p]), len(members[q]), turns[closest])
        members = ([m for i, m in enumerate(members) if i not in (p, q)]
                   + [np.sort(np.concatenate([members[p], members[q]]))])
        rot, shift = _fit_panels(rest, goal, members)
    return members, rot, shift


def panel_weights(rest: np.ndarray, labels: np.ndarray, n_panels: int, width: float,
                  l2: float = 1e-6, fit: np.ndarray | None = None,
                  miss: np.ndarray | None = None) -> np.ndarray:
    """Weights ``(N, P)`` of each panel per particle, with straight boundaries on the rest sheet.

    A multinomial logistic regression on the rest sheet's in-plane coordinates (its two
    principal axes, scaled to its extent; weight decay ``l2``) is fitted to ``labels`` ``(N,)``
    of the particles in ``fit`` (``(N,)`` bool, default all: leave out the particles no panel
    explains better than another, such as the middle of a rounded crease, whose labels would
    only tilt the line). Each of its pairwise boundaries is a line.

    With ``miss`` ``(P, N)`` (each panel's distance to each particle) every particle belongs to
    one panel: the regression's, except that the particles within ``width`` (metres) of the
    line between their two likeliest panels p and q go, all of them, to whichever of p and q
    explains that band better (least summed ``miss``). A crease that runs through a row of
    particles, or cuts it at a shallow angle, then stays one straight step instead of a
    saw-tooth, and a row on the line is not pulled half-way between two layers.

    Without ``miss``, a particle at signed distance d from the p|q line has the factor
    clip(1/2 + d / (2 ``width``), 0, 1) for p, and a panel's weight is the product of its
    factors, normalised: particles on a line get a blend of the two panels.

    Raises:
        TypeError / ValueError: bad rest positions, labels that are not integers in
            ``[0, n_panels)`` of shape ``(N,)``, ``n_panels`` not an int >= 1, ``width`` or ``l2``
            not a finite number > 0 (>= 0 for ``l2``), ``fit`` not an ``(N,)`` bool mask with
            a particle, ``miss`` not a finite ``(P, N)`` array.
    """
    rest, n_panels, labels, fit, miss = _check_weight_args(rest, labels, n_panels, width, l2,
                                                           fit, miss)
    logits, w, extent = _boundary_regression(rest, labels, n_panels, l2, fit)

    def distance(p: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Signed distance (metres, positive on p's side) from the p|q line, per particle."""
        slope = np.linalg.norm(w[:2, p] - w[:2, q], axis=0) / extent           # logit per metre
        rows = np.arange(len(rest))
        return (logits[rows, p] - logits[rows, q]) / np.maximum(slope, 1e-300)

    if miss is not None:
        order = np.argsort(-logits, axis=1, kind="stable")
        first = order[:, 0]
        owner = first.copy()
        if n_panels > 1:
            second = order[:, 1]
            band = distance(first, second) <= width
            low, high = np.minimum(first, second), np.maximum(first, second)
            for a, b in {(int(x), int(y)) for x, y in zip(low[band], high[band], strict=True)}:
                members = band & (low == a) & (high == b)
                owner[members] = a if miss[a, members].sum() <= miss[b, members].sum() else b
        return np.eye(n_panels)[owner]
    weight = np.ones_like(logits)
    for p in range(n_panels):
        for q in range(n_panels):
            if p != q:
                d = distance(np.full(len(rest), p), np.full(len(rest), q))
                weight[:, p] *= np.clip(0.5 + d / (2.0 * width), 0.0, 1.0)
    return weight / weight.sum(axis=1, keepdims=True)


def _check_weight_args(rest, labels, n_panels, width, l2, fit, miss):
    """``panel_weights``' argument checks: ``(rest, n_panels, labels, fit, miss)`` checked
    (``fit`` all True when None, ``miss`` a float array or None); raises as it documents."""
    rest = check_positions(rest, "rest")
    n_panels = check_int(n_panels, "n_panels", 1)
    check_real(width, "width", positive=True)
    check_real(l2, "l2", minimum=0.0)
    labels = check_numeric(labels, "labels")
    if labels.dtype.kind not in "iu":
        raise TypeError(f"labels must be integer panel indices, got dtype {labels.dtype}")
    if labels.shape != (len(rest),):
        raise ValueError(f"labels must have shape ({len(rest)},), got {labels.shape}")
    if np.any((labels < 0) | (labels >= n_panels)):
        raise ValueError(f"labels must lie in [0, {n_panels}), got values "
                         f"{np.unique(labels[(labels < 0) | (labels >= n_panels)])[:5].tolist()}")
    if fit is None:
        fit = np.ones(len(rest), dtype=bool)
    else:
        fit = np.asarray(fit)
        if fit.dtype != bool or fit.shape != (len(rest),) or not fit.any():
            raise ValueError(f"fit must be a ({len(rest)},) bool mask with at least one True")
    if miss is not None:
        miss = np.asarray(check_numeric(miss, "miss"), dtype=float)
        if miss.shape != (n_panels, len(rest)) or not np.all(np.isfinite(miss)):
            raise ValueError(f"miss must be a finite ({n_panels}, {len(rest)}) array, got shape "
                             f"{miss.shape}")
    return rest, n_panels, labels, fit, miss


def _boundary_regression(rest: np.ndarray, labels: np.ndarray, n_panels: int, l2: float,
                         fit: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """``panel_weights``' multinomial logistic regression of ``labels`` ``(N,)`` on the rest
    sheet's in-plane coordinates (scaled to its extent, plus a bias), fitted (L-BFGS, weight
    decay ``l2`` off the bias) to the particles in ``fit``: ``(logits (N, P), weights (3, P),
    extent (metres))``."""
    centred = rest - rest.mean(axis=0)
    plane = centred @ np.linalg.svd(centred, full_matrices=False)[2][:2].T        # (N, 2)
    extent = np.ptp(plane, axis=0).max()
    features = np.c_[plane / extent, np.ones(len(rest))]
    known, count = features[fit], int(fit.sum())
    target = np.eye(n_panels)[labels[fit]]                                   # (n_fit, P)

    def loss(w: np.ndarray) -> tuple[float, np.ndarray]:
        weights = w.reshape(3, n_panels)
        logits = known @ weights
        logits -= logits.max(axis=1, keepdims=True)
        log_p = logits - np.log(np.exp(logits).sum(axis=1, keepdims=True))
        value = -(target * log_p).sum() / count + l2 * (weights[:2] ** 2).sum()
        grad = known.T @ (np.exp(log_p) - target) / count
        grad[:2] += 2.0 * l2 * weights[:2]
        return value, grad.ravel()

    w = minimize(loss, np.zeros(3 * n_panels), jac=True, method="L-BFGS-B").x.reshape(3, n_panels)
    return features @ w, w, extent


def project_on_panels(goal: np.ndarray, rest: np.ndarray, faces: np.ndarray, layer_gap: float,
                      neighbours: int = 9, angle_deg: float = 30.0, min_fraction: float = 0.02,
                      min_width: float = 0.35, crease_width: float = 0.25,
                      tolerance: float | None = None,
                      min_noise: float | None = None,
                      merge_deg: float | None = None) -> PanelFit:
    """Project the particles of a folded cloth goal onto its flat panels (see module doc).

    Args:
        goal: ``(N, 3)`` measured goal positions, metres.
        rest: ``(N, 3)`` flat rest positions (one plane).
        faces: ``(F, 3)`` triangles (their edges decide which particles are neighbours).
        layer_gap: the cloth's layer gap, metres; the default tolerance is one gap (a particle
            on a rounded crease is up to about half a gap from both panels' planes) plus
            3 sqrt(3) times the noise estimate.
        neighbours: particles of the centred local rigid fit (:func:`local_rotations`).
        angle_deg: largest rotation between neighbouring local fits of one panel.
        min_fraction: smallest panel, as a fraction of N (and at least ``neighbours``).
        min_width: smallest panel width (RMS spread across its narrow direction), in particle
            spacings; a row of crease particles is narrower (0), a panel two rows wide is 0.5.
        crease_width: half-width of the band along a boundary whose particles all go to one
            panel, in particle spacings (:func:`panel_weights`).
        tolerance: largest distance moved, metres (``inf``: every particle goes to its
            panel); None for the default above.
        min_noise: with an estimated noise at or below this (metres), nothing moves (the
            boundaries are not fitted); None projects whatever the noise.
        merge_deg: join neighbouring panels whose rigid fits turn by less than this (degrees;
            :func:`_merge_panels`): the pieces of a wrinkled panel. None: no joining.

    Returns:
        :class:`PanelFit`; with no panel found, or too little noise, ``positions`` is ``goal``
        and nothing moves.

    Raises:
        TypeError / ValueError: goal and rest not finite ``(N, 3)`` arrays of one shape, bad
            faces (see :func:`deformables.validation.check_faces`), or an option out of range
            (each named): ``layer_gap`` > 0, ``neighbours`` an int >= 3, ``angle_deg`` in
            (0, 180], ``min_fraction`` in [0, 1], ``min_width`` >= 0, ``crease_width`` > 0,
            ``tolerance`` and ``min_noise`` None or >= 0 (``tolerance`` may be ``inf``),
            ``merge_deg`` None or in (0, 180].
    """
    goal, rest, faces = _check_projection_args(goal, rest, faces, layer_gap, neighbours,
                                               angle_deg, min_fraction, min_width,
                                               crease_width, tolerance, min_noise, merge_deg)
    n = len(goal)
    pairs = edges(faces)
    spacing = float(np.median(np.linalg.norm(rest[pairs[:, 0]] - rest[pairs[:, 1]], axis=1)))
    local_rot, local_rms = local_rotations(rest, goal, spacing, neighbours)
    noise = float(np.median(local_rms))
    members = _panels(rest, pairs, local_rot, spacing, angle_deg,
                      max(int(np.ceil(min_fraction * n)), neighbours), min_width)
    if not members:
        logger.info("panel projection: no flat panel found; goal left as measured")
        return PanelFit(goal, np.full(n, -1), np.zeros((0, 3, 3)), np.zeros((0, 3)), noise,
                        np.zeros(n, dtype=bool))
    if merge_deg is None:
        rot, shift = _fit_panels(rest, goal, members)
    else:
        members, rot, shift = _merge_panels(rest, goal, pairs, members, merge_deg)
    predicted = np.einsum("pij,nj->pni", rot, rest) + shift[:, None]           # (P, N, 3)
    miss = np.linalg.norm(predicted - goal[None], axis=2)                      # (P, N)
    labels = miss.argmin(axis=0)
    noise = float(np.median(miss.min(axis=0)))
    if min_noise is not None and noise <= min_noise:
        logger.info("panel projection: noise %.3g <= %.3g spacings; goal left as measured",
                    noise / spacing, min_noise / spacing)
        return PanelFit(goal, np.full(n, -1), rot, shift, noise, np.zeros(n, dtype=bool))
    labels, own = _panel_predictions(rest, labels, miss, predicted, noise, spacing,
                                     crease_width)
    limit = layer_gap + 3.0 * np.sqrt(3.0) * noise if tolerance is None else tolerance
    moved = np.linalg.norm(own - goal, axis=1) <= limit
    positions = np.where(moved[:, None], own, goal)
    logger.info("panel projection: %d panels, noise %.3g spacings, %d/%d particles moved",
                len(members), noise / spacing, int(moved.sum()), n)
    return PanelFit(positions, np.where(moved, labels, -1), rot, shift, noise, moved)


def _check_projection_args(goal, rest, faces, layer_gap, neighbours, angle_deg, min_fraction,
                           min_width, crease_width, tolerance, min_noise, merge_deg):
    """``project_on_panels``' argument checks: ``(goal, rest, faces)`` checked; raises as it
    documents."""
    goal = check_positions(goal, "goal")
    rest = check_positions(rest, "rest")
    if rest.shape != goal.shape:
        raise ValueError(f"rest {rest.shape} and goal {goal.shape} differ in shape")
    faces = check_faces(faces, len(goal))
    check_real(layer_gap, "layer_gap", positive=True)
    check_int(neighbours, "neighbours", 3)
    check_real(angle_deg, "angle_deg", positive=True, maximum=180.0)
    check_real(min_fraction, "min_fraction", minimum=0.0, maximum=1.0)
    check_real(min_width, "min_width", minimum=0.0)
    check_real(crease_width, "crease_width", positive=True)
    if tolerance is not None and tolerance != np.inf:       # inf: every particle moves
        check_real(tolerance, "tolerance", minimum=0.0)
    if min_noise is not None:
        check_real(min_noise, "min_noise", minimum=0.0)
    if merge_deg is not None:
        check_real(merge_deg, "merge_deg", positive=True, maximum=180.0)
    return goal, rest, faces


def _panel_predictions(rest: np.ndarray, labels: np.ndarray, miss: np.ndarray,
                       predicted: np.ndarray, noise: float, spacing: float,
                       crease_width: float) -> tuple[np.ndarray, np.ndarray]:
    """``(labels (N,), own (N, 3))`` of ``project_on_panels``: each particle's panel and the
    position its panel predicts, from each panel's ``predicted`` positions ``(P, N, 3)`` and
    distances ``miss`` ``(P, N)``. With more than one panel the boundaries are straight lines
    of the rest sheet (:func:`panel_weights`, bands ``crease_width`` spacings wide)."""
    if len(predicted) > 1:
        # a particle two panels explain about as well (the middle of a rounded crease) says
        # nothing of where the boundary runs
        ranked = np.sort(miss, axis=0)
        clear = ranked[1] - ranked[0] > max(3.0 * noise, 1e-3 * spacing)
        weights = panel_weights(rest, labels, len(predicted), crease_width * spacing,
                                fit=clear if clear.any() else None, miss=miss)
        labels = weights.argmax(axis=1)
        own = np.einsum("np,pni->ni", weights, predicted)
    else:
        own = predicted[0]
    return labels, own
