"""Output channels of a simulation, from Newmark states: names, values, tacho pulses.

Channel names carry their unit. Per case: housing/bearing accelerations along the line of action
(``acc_*_loa_m_s2``; axial too for helical pairs), bearing forces (``force_bearing_*_n``), dynamic
transmission error ``dte_m = rb1 phi1 - rb2 phi2``, mesh deflection ``mesh_deflection_m = v . q``,
mesh force, shaft speeds, and the once-per-revolution ``tacho_*`` pulses (from the actual shaft
angles). ``_phi_*`` are internal (for the tacho) and dropped from the output.
"""
from __future__ import annotations

import numpy as np

def channel_names(n: int) -> list[str]:
    names = ["acc_pinion_loa_m_s2", "acc_wheel_loa_m_s2", "force_bearing_pinion_loa_n", "force_bearing_wheel_loa_n"]
    if n == 8:
        names += ["acc_pinion_axial_m_s2", "acc_wheel_axial_m_s2", "force_bearing_pinion_axial_n",
                  "force_bearing_wheel_axial_n"]
    return names + ["dte_m", "mesh_deflection_m", "mesh_force_n", "speed_pinion_rpm", "speed_wheel_rpm", "_phi_1",
                    "_phi_2"]


def channel_coefficients(cases) -> dict:
    m0 = cases[0].model
    n = m0.n
    ix = {d: i for i, d in enumerate(m0.dofs)}
    co = {"ix": ix, "n": n}
    for d in ("y_1", "y_2", "z_1", "z_2"):
        if d in ix:
            co[f"k_{d}"] = np.array([c.model.K_s[ix[d], ix[d]] for c in cases])
            co[f"c_{d}"] = np.array([c.model.C_s[ix[d], ix[d]] for c in cases])
    co["rb1"] = np.array([c.model.pair.base_radius_m("pinion") for c in cases])
    co["rb2"] = np.array([c.model.pair.base_radius_m("wheel") for c in cases])
    co["gear_ratio"] = np.array([c.model.ratio[ix["phi_2"]] for c in cases])
    co["v"] = np.stack([c.model.v for c in cases])
    return co


def fine_names(n: int, wanted=None) -> list[str]:
    """The fine-rate channels (:func:`channel_names` order) that make the output channels ``wanted`` (a set of
    names; None: every channel). A ``tacho_*`` pulse needs its shaft's ``_phi`` channel."""
    names = channel_names(n)
    if wanted is None:
        return names
    need = set(wanted)
    if "tacho_pinion" in need:
        need.add("_phi_1")
    if "tacho_wheel" in need:
        need.add("_phi_2")
    return [nm for nm in names if nm in need] or names   # none of them (unknown names): all, so the error lists them


#: the state components each solver channel is made of (:func:`channel_values`): (part, DOF), part "q", "qd" or
#: "qdd"; "all_q" is every displacement (the mesh deflection v . q)
_SOURCES = {"acc_pinion_loa_m_s2": (("qdd", "y_1"),), "acc_wheel_loa_m_s2": (("qdd", "y_2"),),
            "acc_pinion_axial_m_s2": (("qdd", "z_1"),), "acc_wheel_axial_m_s2": (("qdd", "z_2"),),
            "force_bearing_pinion_loa_n": (("q", "y_1"), ("qd", "y_1")),
            "force_bearing_wheel_loa_n": (("q", "y_2"), ("qd", "y_2")),
            "force_bearing_pinion_axial_n": (("q", "z_1"), ("qd", "z_1")),
            "force_bearing_wheel_axial_n": (("q", "z_2"), ("qd", "z_2")),
            "dte_m": (("q", "phi_1"), ("q", "phi_2")), "mesh_deflection_m": (("all_q", None),), "mesh_force_n": (),
            "speed_pinion_rpm": (("qd", "phi_1"),), "speed_wheel_rpm": (("qd", "phi_2"),),
            "_phi_1": (("q", "phi_1"),), "_phi_2": (("q", "phi_2"),)}


def state_rows(n: int, ix: dict, names: list[str]) -> list[int]:
    """The components of the Newmark state ``(q, q', q'')`` (3n) that :func:`channel_values` reads to make
    ``names`` (sorted)."""
    offset = {"q": 0, "qd": n, "qdd": 2 * n}
    need = set()
    for nm in names:
        for part, dof in _SOURCES[nm]:
            need |= set(range(n)) if part == "all_q" else {offset[part] + ix[dof]}
    return sorted(need)


def channel_values(traj: np.ndarray, force: np.ndarray, omega: np.ndarray, co: dict,
                   names: list[str] | None = None) -> np.ndarray:
    """Fine-rate channels (C, n_ch, L) from states (C, 3n, L), mesh force (C, L) and pinion reference
    speed (rad/s, broadcastable to (C, L)); ``names`` (default: :func:`channel_names`) picks and orders them."""
    n, ix = co["n"], co["ix"]
    q, qd, qdd = traj[:, :n], traj[:, n:2 * n], traj[:, 2 * n:]

    def c(name):
        return co[name][:, None]

    def bearing(d):
        return lambda: c(f"k_{d}") * q[:, ix[d]] + c(f"c_{d}") * qd[:, ix[d]]

    rpm = 60.0 / (2 * np.pi)
    make = {"acc_pinion_loa_m_s2": lambda: qdd[:, ix["y_1"]], "acc_wheel_loa_m_s2": lambda: qdd[:, ix["y_2"]],
            "force_bearing_pinion_loa_n": bearing("y_1"), "force_bearing_wheel_loa_n": bearing("y_2"),
            "dte_m": lambda: c("rb1") * q[:, ix["phi_1"]] - c("rb2") * q[:, ix["phi_2"]],
            "mesh_deflection_m": lambda: np.einsum("cil,ci->cl", q, co["v"]),
            "mesh_force_n": lambda: force,
            "speed_pinion_rpm": lambda: (omega + qd[:, ix["phi_1"]]) * rpm,
            "speed_wheel_rpm": lambda: (omega * c("gear_ratio") + qd[:, ix["phi_2"]]) * rpm,
            "_phi_1": lambda: q[:, ix["phi_1"]], "_phi_2": lambda: q[:, ix["phi_2"]]}
    if n == 8:
        make.update({"acc_pinion_axial_m_s2": lambda: qdd[:, ix["z_1"]],
                     "acc_wheel_axial_m_s2": lambda: qdd[:, ix["z_2"]],
                     "force_bearing_pinion_axial_n": bearing("z_1"), "force_bearing_wheel_axial_n": bearing("z_2")})
    names = channel_names(n) if names is None else names
    L = traj.shape[2]
    return np.stack([np.broadcast_to(make[nm](), (traj.shape[0], L)) for nm in names], axis=1)


def tacho(theta: np.ndarray) -> np.ndarray:
    """Once-per-revolution pulse: 1 at the first sample on or after each whole turn, else 0."""
    turns = np.floor(theta / (2 * np.pi))
    pulse = np.zeros_like(theta)
    pulse[1:] = (turns[1:] > turns[:-1]).astype(float)
    return pulse


def finish(values: np.ndarray, names: list[str], theta1: np.ndarray, ratio: float) -> dict:
    """Per-case dict of output channels (rows of ``values``, (n_ch, n_out)) incl. the tacho pulses of the shafts
    whose ``_phi`` channel is among ``names``; internal ``_phi`` channels dropped."""
    ch = {nm: values[j] for j, nm in enumerate(names) if not nm.startswith("_")}
    if "_phi_1" in names:
        ch["tacho_pinion"] = tacho(theta1 + values[names.index("_phi_1")])
    if "_phi_2" in names:
        ch["tacho_wheel"] = tacho(theta1 * ratio + values[names.index("_phi_2")])
    return ch
