"""How a pit map changes the compliances of the slices it touches.

:func:`datagen.stiffness.mesh_stiffness` assembles the healthy record from the
pair compliance table (:func:`datagen.compliance.pair_compliance`); this module
recomputes the slices of the pitted engagements only (PHYSICS.md section 3):

- Pits (``pit_model="no_contact"``, default): a pitted pixel on the contact line
  carries no load (a 0.1-0.2 mm deep pit does not close under load), so that
  slice of that pair drops out while it is there (a pixel a pit covers only in
  part, :attr:`datagen.flank.PitMap.coverage`, keeps its intact share of that
  stiffness); in addition the material the pits remove lowers the section (area, second moment) of that slice for every
  load point above them (Ma et al. 2015; Chen & Shao 2011).
  ``pit_model="weak_spring"`` is the spur paper's "weak spring": a pitted pixel
  stays loaded, its contact spring weakened to :data:`WEAK_SPRING_RATIO` of the
  healthy Hertzian stiffness (the paper gives no ratio; its text "the contact
  stiffness of pitting area will not be considered" was implemented here before
  stop 63 by dropping the Hertzian *compliance*, which made a pitted pixel 7 %
  stiffer than a healthy one: +3.5 MN/m on spur-gds while the pit meshed, against
  -48 MN/m for no contact), with the same section loss: a milder drop than no
  contact, never a rise.
- The section loss of a tooth is accumulated row by row from the start of
  active profile up, as increments of the section integrals ``W_n``, ``A_0`` of
  :mod:`datagen.compliance`; a pit removes at most 90 % of the local thickness.

:func:`pixel_stiffness_map` draws the same model pixel by pixel (the spur
paper's stiffness distribution picture).

References
----------
Ma, H., Li, Z., Feng, M., Feng, R., Wen, B. (2015). Time-varying mesh stiffness calculation of spur gear
    pairs considering tooth spalling. Eng. Fail. Anal. 66, 166-176.
Chen, Z., Shao, Y. (2011). Dynamic simulation of spur gear with tooth root crack propagating along tooth
    width and crack depth. Eng. Fail. Anal. 18, 2149-2164.
The spur paper: ../shared/seeds/000_3879ffd8da6fd0be.txt (pixel / weak-spring model).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from datagen.compliance import PairCompliance, ToothBeam, beam_compliance, pair_compliance
from datagen.flank import PitMap
from datagen.pitshapes import DEPTH_RANGE_M
from gearpit.errors import InputError, require

PIT_MODELS = ("no_contact", "weak_spring")
#: ``weak_spring``: a pitted pixel's Hertzian stiffness as a fraction of the healthy one (its Hertzian compliance
#: divided by it); our choice, the spur paper names none
WEAK_SPRING_RATIO = 0.1

#: a pit may remove at most this fraction of the section thickness (keeps 1/I finite)
_MAX_THICKNESS_LOSS = 0.9


def normalise_pits(pair, pits) -> tuple[PitMap, ...]:
    """``pits`` (None, a PitMap or a sequence of PitMaps) as a tuple, checked against the flanks of ``pair``."""
    if pits is None:
        return ()
    maps = (pits,) if isinstance(pits, PitMap) else tuple(pits)
    seen = set()
    for pm in maps:
        require(isinstance(pm, PitMap), "pits", type(pm).__name__, "a PitMap or a sequence of PitMaps")
        require(pm.gear not in seen, "pits.gear", pm.gear, "at most one pit map per gear")
        seen.add(pm.gear)
        expected = pair.flank_grid(pm.gear, pm.grid.n_profile, pm.grid.n_face)
        for name in ("profile_length_m", "face_width_m", "contact_face_width_m"):
            got, want = getattr(pm.grid, name), getattr(expected, name)
            if not math.isclose(got, want, rel_tol=1e-6):
                raise InputError(f"pits.grid.{name}", got, f"{want:.6g} (the {pm.gear} flank of pair {pair.name})")
        z = pair._gear(pm.gear).teeth
        deepest = DEPTH_RANGE_M[1]
        for t, d in pm.depth_m.items():
            require(t < z, "pits.tooth", t, f"a tooth index in [0, {z - 1}] of the {pm.gear}")
            d = np.asarray(d, float)
            require(bool(np.all(np.isfinite(d))) and float(d.min()) >= 0.0 and float(d.max()) <= deepest,
                    f"pits.depth_m[{t}]", f"{float(np.nanmin(d)):.3g} .. {float(np.nanmax(d)):.3g} m",
                    f"depths in [0, {deepest:g}] m (a map written in mm and read as metres is 1000 times too deep)")
    return maps


@dataclass(frozen=True, eq=False)
class _PitGeometry:
    """Per pitted tooth: cumulative section loss (rows+1, cols) and the pitted share of each pixel."""

    share: np.ndarray
    dW: np.ndarray   # (3, rows+1, cols)
    dA0: np.ndarray  # (rows+1, cols)


def _section_loss(pair, beam: ToothBeam, which: str, depth: np.ndarray, grid, share: np.ndarray | None = None
                  ) -> _PitGeometry:
    """Cumulative W_n, A_0 increments that the pits of one tooth cause, row by row from the SAP up. ``share``:
    the pitted share of each pixel (:meth:`datagen.flank.PitMap.share`; default: whole pixels where the depth is
    > 0); a partly pitted pixel removes that share of its depth's material (its depth times its share)."""
    if share is None:
        share = (depth > 0).astype(np.float64)
    depth = depth * share
    rb = beam.base_radius_m
    t_sap, _ = pair.active_roll_range_rad(which)
    s_edges = np.arange(grid.n_profile + 1) * grid.ds_m
    t_edges = np.sqrt(t_sap**2 + 2.0 * s_edges / rb)
    a = beam.alpha2_rad - t_edges
    y_edges = rb * (np.cos(a) - t_edges * np.sin(a)) - beam.y_root_m
    t_mid = 0.5 * (t_edges[1:] + t_edges[:-1])
    a_mid = beam.alpha2_rad - t_mid
    z_mid = rb * (np.cos(a_mid) - t_mid * np.sin(a_mid)) - beam.y_root_m
    thick = 2.0 * rb * (t_mid * np.cos(a_mid) + np.sin(a_mid))
    dy = np.diff(y_edges)
    loss = np.minimum(depth, _MAX_THICKNESS_LOSS * thick[:, None])
    t_pit = thick[:, None] - loss
    d_inv_i = 12.0 / t_pit**3 - 12.0 / thick[:, None] ** 3
    d_inv_a = 1.0 / t_pit - 1.0 / thick[:, None]
    dW = np.zeros((3, grid.n_profile + 1, grid.n_face))
    for n in range(3):
        dW[n, 1:] = np.cumsum(d_inv_i * (z_mid**n * dy)[:, None], axis=0)
    dA0 = np.zeros((grid.n_profile + 1, grid.n_face))
    dA0[1:] = np.cumsum(d_inv_a * dy[:, None], axis=0)
    return _PitGeometry(share=share, dW=dW, dA0=dA0)


def slice_pieces(w_slices, dw: float, grids_offsets) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where the slices and the face columns of the pitted grids overlap.

    The slices' edges and every grid's column edges (shifted by its contact offset) cut the contact face into
    pieces; each lies in one slice and one column of each grid. Returns the slice of each piece, its column on
    each grid ``(n_grids, pieces)`` and its share of the slice's width (1 when slices and columns coincide).
    """
    n = w_slices.size
    s_edges = np.arange(n + 1) * dw
    cuts = [s_edges]
    for grid, offset in grids_offsets:
        c = np.arange(grid.n_face + 1) * grid.dw_m - offset
        c = c[(c > 0) & (c < n * dw)]
        near_slice_edge = np.abs(c / dw - np.rint(c / dw)) < 1e-9   # a slice edge already cuts there
        cuts.append(c[~near_slice_edge])
    edges = np.unique(np.concatenate(cuts))
    mid = 0.5 * (edges[1:] + edges[:-1])
    sl = np.clip((mid / dw).astype(np.int64), 0, n - 1)
    cols = np.array([np.clip(((mid + offset) / grid.dw_m).astype(np.int64), 0, grid.n_face - 1)
                     for grid, offset in grids_offsets]).reshape(len(grids_offsets), mid.size)
    share = np.diff(edges) / dw
    share[np.abs(share - 1.0) < 1e-9] = 1.0
    return sl, cols, share


def pit_overrides(pair, pc: PairCompliance, maps, P: int, g_cycle, dw: float, w_slices, pit_model: str) -> dict:
    """Slice stiffness of every pitted engagement, keyed by (engagement m, slot).

    A slice sees every face column it covers: it is cut into pieces where it meets the columns of the pitted
    grids (:func:`slice_pieces`), each piece takes the slice's contact position and the section loss, contact
    (no_contact) or weakened spring (weak_spring) of its own column, and the slice's stiffness is the sum of its
    pieces' ``share * dw / compliance`` (uncoupled, like the slices). With one slice per column, as by default on
    a spur pair, each slice is one piece and this is the old per-column model; with fewer slices than columns a
    pit covering half a slice takes half of it (the slice centre used to decide it all: a 20 % ellipse made the
    pitted tooth's single slice carry nothing).
    """
    if not any(pm.pitted_teeth for pm in maps):
        return {}
    E, G = pair.material.youngs_modulus_pa, pair.material.shear_modulus_pa
    b_c = pair.contact_face_width_m
    pitted_maps = [pm for pm in maps if pm.pitted_teeth]
    offsets = [(pm.grid, (pair._gear(pm.gear).face_width_m - b_c) / 2.0) for pm in pitted_maps]
    piece_slice, piece_cols, piece_share = slice_pieces(w_slices, dw, offsets)
    per_gear = {}
    for i, pm in enumerate(pitted_maps):
        beam = pc.beams[pm.gear]
        cols = piece_cols[i]
        geo = {}
        for t in pm.pitted_teeth:
            pg = _section_loss(pair, beam, pm.gear, pm.depth_m[t], pm.grid, pm.share(t))
            # the pieces whose face column holds a pit somewhere: on the others the section increments are exact
            # zeros, so the bending, shear and axial terms add +0.0 and the compliance is the healthy one
            touched = ((pg.dW != 0.0).any(axis=(0, 1)) | (pg.dA0 != 0.0).any(axis=0))[cols]
            geo[t] = (pg, touched)
        per_gear[pm.gear] = (pm, beam, cols, geo)
    z = {"pinion": pair.pinion.teeth, "wheel": pair.wheel.teeth}
    engaged = sorted({m for gear, (pm, *_rest) in per_gear.items() for m in range(P) if m % z[gear] in pm.pitted_teeth})
    # per slot, the same for every engagement: contact, contact positions, healthy compliance; on unstaggered
    # slices (a spur pair's pixel columns), which share their positions, the first slice's positions stand for all
    # pitted pieces (the load point is elementwise, so the same values)
    slots = {}
    for s in range(g_cycle.shape[1]):
        g = g_cycle[:, s, :]
        contact = ~np.isnan(g)
        if contact.any():
            g0 = np.where(contact, g, pair.contact_start_m)
            slots[s] = (contact, g0, pc(g0), g0[:, :1] if bool(np.all(g0 == g0[:, :1])) else None)
    out = {}
    n_slices = w_slices.size
    for m in engaged:
        touched = np.zeros(piece_slice.size, bool)
        for gear, (pm, beam, cols, geo) in per_gear.items():
            if m % z[gear] in geo:
                touched |= geo[m % z[gear]][1]
        sel = np.nonzero(touched)[0]
        if sel.size == 0:
            continue
        psl, share = piece_slice[sel], piece_share[sel]
        intact_share = 1.0 - np.bincount(psl, weights=share, minlength=n_slices)
        intact_share[np.abs(intact_share) < 1e-9] = 0.0
        for s, (contact, g0, comp_healthy, g_pit) in slots.items():
            comp = comp_healthy[:, psl]
            intact_here = np.ones(comp.shape)          # share of the piece's contact no pit covers
            for gear, (pm, beam, cols, geo) in per_gear.items():
                tooth = m % z[gear]
                if tooth not in geo:
                    continue
                pg, _ = geo[tooth]
                t_sap, _ = pair.active_roll_range_rad(gear)
                roll = pair.roll_angle_rad(gear, g0[:, psl] if g_pit is None else g_pit)
                s_arc = beam.base_radius_m * (roll**2 - t_sap**2) / 2.0
                rows = np.clip((s_arc / pm.grid.ds_m).astype(np.int64), 0, pm.grid.n_profile - 1)
                rows, colg = np.broadcast_arrays(rows, cols[sel][None, :])
                intact_here = intact_here * (1.0 - pg.share[rows, colg])
                a1, Y, h = beam.load_point(roll)
                W = pg.dW[:, rows, colg]
                b, sh, ax = beam_compliance(a1, Y, h, W, pg.dA0[rows, colg], E, G)
                comp = comp + b + sh + ax
            in_contact = contact[:, psl]
            if pit_model == "no_contact":
                k_piece = np.where(in_contact, intact_here * dw / comp, 0.0)
            else:
                weak = comp + pc.c_hertz * (1.0 / WEAK_SPRING_RATIO - 1.0)
                k_piece = np.where(in_contact, intact_here * dw / comp + (1.0 - intact_here) * dw / weak, 0.0)
            k = np.where(contact, dw / comp_healthy, 0.0) * intact_share[None, :]
            np.add.at(k, (slice(None), psl), share[None, :] * k_piece)
            out[(m, s)] = k
    return out


def pixel_stiffness_map(pair, pit_map: PitMap, tooth: int, *, pit_model: str = "no_contact") -> np.ndarray:
    """Stiffness of each flank pixel while it is on the contact line (N/m per pixel column).

    The spur paper's "stiffness distribution" picture (its Figs 11-12): row
    ``i`` at its contact position, column ``j`` as a slice of the pixel's width.
    """
    require(pit_model in PIT_MODELS, "pit_model", pit_model, f"one of: {', '.join(PIT_MODELS)}")
    grid = pit_map.grid
    pc = pair_compliance(pair)
    beam = pc.beams[pit_map.gear]
    t_sap, _ = pair.active_roll_range_rad(pit_map.gear)
    roll = np.sqrt(t_sap**2 + 2.0 * grid.s_centres_m / beam.base_radius_m)
    if pit_map.gear == "pinion":
        g = roll * beam.base_radius_m
    else:
        g = pair.line_of_action_length_m - roll * beam.base_radius_m
    comp = np.repeat(pc(g)[:, None], grid.n_face, axis=1)
    depth = pit_map.depth_m.get(tooth, np.zeros(grid.shape))
    share = pit_map.share(tooth)
    pg = _section_loss(pair, beam, pit_map.gear, depth, grid, share)
    a1, Y, h = beam.load_point(roll)
    rows = np.arange(grid.n_profile)
    b, sh, ax = beam_compliance(a1[:, None], Y[:, None], h[:, None], pg.dW[:, rows, :], pg.dA0[rows, :],
                                pair.material.youngs_modulus_pa, pair.material.shear_modulus_pa)
    comp = comp + b + sh + ax
    if pit_model == "no_contact":
        return (1.0 - share) * grid.dw_m / comp
    return (1.0 - share) * grid.dw_m / comp + share * grid.dw_m / (comp + pc.c_hertz * (1.0 / WEAK_SPRING_RATIO - 1.0))
