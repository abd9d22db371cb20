"""Lumped-parameter drive train: motor, coupling/shaft, pinion, mesh, wheel, shaft/coupling, load.

Generalized coordinates (the vibratory part about the nominal rotation,
``theta_i(t) = ratio_i * theta_ref(t) + phi_i(t)``, so rigid-body drift never
enters; ``theta_ref`` = integral of the pinion reference speed):

====  ===========  =======  ==========================================================
idx   name         unit     meaning
====  ===========  =======  ==========================================================
0     ``phi_m``    rad      motor rotor angle (ratio 1)
1     ``phi_1``    rad      pinion angle (ratio 1)
2     ``y_1``      m        pinion centre, along the transverse line of action
3     ``phi_2``    rad      wheel angle (ratio z1/z2)
4     ``y_2``      m        wheel centre, along the line of action
5     ``phi_b``    rad      load (brake) rotor angle (ratio z1/z2)
6     ``z_1``      m        pinion axial displacement (helical pairs only)
7     ``z_2``      m        wheel axial displacement (helical pairs only)
====  ===========  =======  ==========================================================

Equations (spur paper's model, PHYSICS.md section 4, plus a speed controller)::

    M q'' + C_s q' + K_s q + v F = f,        delta = v . q,   F = k(x) delta + c_m delta' - E

with the mesh vector ``v = (0, rb1, 1, -rb2, -1, 0[, tan(beta_b), -tan(beta_b)])``:
the transverse line-of-action deflection is ``rb1 phi1 - rb2 phi2 + y1 - y2``
and, for helical pairs, ``+ tan(beta_b) (z1 - z2)``, so that the axial mesh
force is ``F tan(beta_b)`` (energy-consistent). Shafts are torsional springs
(bending-rigid, PHYSICS.md); bearings are springs and dampers along the line of
action (and axially); the helical tilting moment ``F tan(beta_b) r`` is not
modelled (bending-rigid shafts). ``f`` holds the motor torque ``T1`` on
``phi_m`` and the load torque ``-T1 z2/z1`` on ``phi_b``, so the static mesh
force is ``T1 / rb1``. The motor is speed-controlled (the spur paper's rig: an
AC motor with speed-control electronics): a PI controller acting on the motor
angle error is a torsional spring-damper to the reference rotation, which also
removes the rigid-body mode.

Parameters and defaults (:class:`DriveTrain`; the spur paper's Table 1 values
come from KISSsoft and are not in the available text, so every number below is
an assumption of ours with its basis):

- gear masses and inertias: :meth:`GearPair.mass_kg` / ``inertia_kg_m2`` (ring bore -> pitch circle);
- ``motor_inertia_kg_m2 = 0.01``: rotor of a 2-3 kW 4-pole induction motor (catalogue range 0.005-0.02);
- ``load_inertia_kg_m2 = 0.05``: rotor of a small electromagnetic brake plus coupling hub;
- ``input_shaft_nm_per_rad = 5e3``: 25 mm steel shaft, 0.3 m (G J / L = 1.1e4) in series with a flexible coupling;
- ``output_shaft_nm_per_rad = 1e4``: the same for the stiffer output shaft;
- ``shaft_damping_ratio = 0.02``: on each shaft's two-inertia torsion mode (steel shafts 0.01-0.05);
- ``bearing_n_per_m = 1e8`` radial, ``bearing_axial_n_per_m = 5e7``: rolling-element supports, both
  bearings of a gear together (Harris & Kotzalas, Rolling Bearing Analysis: 1e8-1e9 N/m radial);
- ``bearing_damping_ratio = 0.05``: on each gear-on-bearing mode, c = 2 zeta sqrt(k m);
- ``mesh_damping_ratio = 0.07``: PHYSICS.md range 0.03-0.1; ``c_m`` makes the modal damping ratio of
  the *mesh mode* (the mode with the largest share of strain energy in the mean mesh spring) equal it;
- ``speed_control_hz = 5``, ``speed_control_damping_ratio = 0.7``: closed-loop speed bandwidth of a
  V/f-drive with slip compensation (a few Hz), on the whole train's inertia reflected to the motor.

References
----------
The spur paper (../shared/seeds/000_3879ffd8da6fd0be.txt), "Dynamic model of the gear system".
Kahraman, A. (1994). Dynamic analysis of a multi-mesh helical gear train. J. Mech. Des. 116, 706-712
    (axial mesh coupling through tan(beta_b)).
Parker, R. G., Vijayakar, S. M., Imajo, T. (2000). Non-linear dynamic response of a spur gear pair.
    J. Sound Vib. 237(3), 435-455 (mesh damping from a modal damping ratio).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from functools import cached_property

import numpy as np
import scipy.linalg

from gearpit.errors import InputError, require_positive, require_range

SPUR_DOFS = ("phi_m", "phi_1", "y_1", "phi_2", "y_2", "phi_b")
HELICAL_DOFS = SPUR_DOFS + ("z_1", "z_2")


@dataclass(frozen=True)
class DriveTrain:
    """Everything of the lumped model that is not the gear pair (SI units; see module docstring)."""

    motor_inertia_kg_m2: float = 0.01
    load_inertia_kg_m2: float = 0.05
    input_shaft_nm_per_rad: float = 5e3
    output_shaft_nm_per_rad: float = 1e4
    shaft_damping_ratio: float = 0.02
    bearing_n_per_m: float = 1e8
    bearing_axial_n_per_m: float = 5e7
    bearing_damping_ratio: float = 0.05
    mesh_damping_ratio: float = 0.07
    speed_control_hz: float = 5.0
    speed_control_damping_ratio: float = 0.7

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name.endswith("damping_ratio"):
                require_range(f"drivetrain.{f.name}", v, 0.0, 2.0)
            else:
                require_positive(f"drivetrain.{f.name}", v)

    @classmethod
    def from_dict(cls, d: dict, where: str = "drivetrain") -> "DriveTrain":
        known = {f.name for f in fields(cls)}
        for k in d:
            if k not in known:
                raise InputError(f"{where}.{k}", d[k], f"a known key: {', '.join(sorted(known))}")
        return cls(**{k: float(v) if isinstance(v, int) and not isinstance(v, bool) else v for k, v in d.items()})

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True, eq=False)
class LumpedModel:
    """Matrices of the lumped model for one pair, drive train and mean mesh stiffness.

    Attributes
    ----------
    dofs : tuple of str
    M, K_s, C_s : ndarray (n, n)
        Mass, structural stiffness (shafts, bearings, speed controller) and damping.
    v : ndarray (n,)
        Mesh vector: delta = v . q (m).
    ratio : ndarray (n,)
        Rotation of each DOF per radian of the pinion reference (1, z1/z2 or 0).
    f_static : ndarray (n,)
        Motor and load torques at the nominal torque (N m).
    k_mean_n_per_m, c_mesh_n_s_per_m : float
        Mean mesh stiffness and the mesh damping coefficient.
    """

    pair: object
    drive: DriveTrain
    dofs: tuple
    M: np.ndarray
    K_s: np.ndarray
    C_s: np.ndarray
    v: np.ndarray
    ratio: np.ndarray
    f_static: np.ndarray
    torque_nm: float
    k_mean_n_per_m: float
    c_mesh_n_s_per_m: float

    @property
    def n(self) -> int:
        return len(self.dofs)

    def index(self, name: str) -> int:
        return self.dofs.index(name)

    @cached_property
    def K_mean(self) -> np.ndarray:
        return self.K_s + self.k_mean_n_per_m * np.outer(self.v, self.v)

    @cached_property
    def C_mean(self) -> np.ndarray:
        return self.C_s + self.c_mesh_n_s_per_m * np.outer(self.v, self.v)

    @cached_property
    def modes(self) -> tuple[np.ndarray, np.ndarray]:
        """Undamped natural frequencies (rad/s, ascending) and mass-normalised mode shapes of the mean system."""
        w2, phi = scipy.linalg.eigh(self.K_mean, self.M)
        return np.sqrt(np.maximum(w2, 0.0)), phi

    @property
    def natural_frequencies_hz(self) -> np.ndarray:
        return self.modes[0] / (2 * np.pi)

    @property
    def modal_damping_ratios(self) -> np.ndarray:
        """phi_j' C phi_j / (2 w_j) of the mean system (light, near-proportional damping)."""
        w, phi = self.modes
        return np.einsum("ij,ik,kj->j", phi, self.C_mean, phi) / (2 * w)

    @property
    def mesh_mode_index(self) -> int:
        """Mode with the largest fraction of strain energy in the mean mesh spring."""
        return _mesh_mode(self.K_mean, self.M, self.v, self.k_mean_n_per_m)

    @property
    def slowest_decay_s(self) -> float:
        """Longest modal decay time constant 1/(zeta w) of the mean system (s)."""
        return float(np.max(1.0 / (self.modal_damping_ratios * self.modes[0])))

    def static_deflection(self, error_force_n: float = 0.0, torque_nm: float | None = None) -> np.ndarray:
        """Static equilibrium q0 of the mean system under load: K_mean q0 = f + v E."""
        f = self.f_static if torque_nm is None else self.f_static * (torque_nm / self.torque_nm if self.torque_nm else 0)
        return np.linalg.solve(self.K_mean, f + self.v * error_force_n)

    def time_step_s(self, omega_dt: float = 0.3) -> float:
        """Largest time step with omega_max * dt <= omega_dt on the mean-stiffness system."""
        return omega_dt / float(self.modes[0][-1])


def _mesh_mode(K, M, v, k_mean) -> int:
    w2, phi = scipy.linalg.eigh(K, M)
    energy = k_mean * (v @ phi) ** 2 / np.maximum(w2, 1e-30)
    return int(np.argmax(energy))


def build_model(pair, drive: DriveTrain, *, k_mean_n_per_m: float, torque_nm: float) -> LumpedModel:
    """Assemble the lumped model (module docstring) for ``pair`` under ``torque_nm`` on the pinion shaft."""
    require_positive("k_mean_n_per_m", k_mean_n_per_m)
    helical = pair.is_helical
    dofs = HELICAL_DOFS if helical else SPUR_DOFS
    n = len(dofs)
    ix = {d: i for i, d in enumerate(dofs)}
    z1, z2 = pair.pinion.teeth, pair.wheel.teeth
    rb1, rb2 = pair.base_radius_m("pinion"), pair.base_radius_m("wheel")
    I1, I2 = pair.inertia_kg_m2("pinion"), pair.inertia_kg_m2("wheel")
    m1, m2 = pair.mass_kg("pinion"), pair.mass_kg("wheel")
    Im, Ib = drive.motor_inertia_kg_m2, drive.load_inertia_kg_m2
    masses = {"phi_m": Im, "phi_1": I1, "y_1": m1, "phi_2": I2, "y_2": m2, "phi_b": Ib, "z_1": m1, "z_2": m2}
    M = np.diag([masses[d] for d in dofs])
    K = np.zeros((n, n))
    C = np.zeros((n, n))

    def spring(a: str, b: str | None, k: float, c: float):
        i = ix[a]
        K[i, i] += k
        C[i, i] += c
        if b is not None:
            j = ix[b]
            K[j, j] += k
            C[j, j] += c
            K[i, j] -= k
            K[j, i] -= k
            C[i, j] -= c
            C[j, i] -= c

    def two_inertia_damping(k, Ia, Ib_, zeta):
        return 2 * zeta * math.sqrt(k * Ia * Ib_ / (Ia + Ib_))

    ks1, ks2 = drive.input_shaft_nm_per_rad, drive.output_shaft_nm_per_rad
    spring("phi_m", "phi_1", ks1, two_inertia_damping(ks1, Im, I1, drive.shaft_damping_ratio))
    spring("phi_2", "phi_b", ks2, two_inertia_damping(ks2, I2, Ib, drive.shaft_damping_ratio))
    kb = drive.bearing_n_per_m
    spring("y_1", None, kb, 2 * drive.bearing_damping_ratio * math.sqrt(kb * m1))
    spring("y_2", None, kb, 2 * drive.bearing_damping_ratio * math.sqrt(kb * m2))
    if helical:
        ka = drive.bearing_axial_n_per_m
        spring("z_1", None, ka, 2 * drive.bearing_damping_ratio * math.sqrt(ka * m1))
        spring("z_2", None, ka, 2 * drive.bearing_damping_ratio * math.sqrt(ka * m2))
    i_reflected = Im + I1 + (I2 + Ib) * (z1 / z2) ** 2
    k_ctrl = i_reflected * (2 * math.pi * drive.speed_control_hz) ** 2
    spring("phi_m", None, k_ctrl, 2 * drive.speed_control_damping_ratio * math.sqrt(k_ctrl * i_reflected))

    v = np.zeros(n)
    v[ix["phi_1"]], v[ix["y_1"]], v[ix["phi_2"]], v[ix["y_2"]] = rb1, 1.0, -rb2, -1.0
    if helical:
        tb = math.tan(pair.base_helix_angle_rad)
        v[ix["z_1"]], v[ix["z_2"]] = tb, -tb
    ratio = np.zeros(n)
    ratio[[ix["phi_m"], ix["phi_1"]]] = 1.0
    ratio[[ix["phi_2"], ix["phi_b"]]] = z1 / z2
    f = np.zeros(n)
    f[ix["phi_m"]] = torque_nm
    f[ix["phi_b"]] = -torque_nm * z2 / z1

    # mesh damping: modal damping ratio of the mesh mode = drive.mesh_damping_ratio
    K_mean = K + k_mean_n_per_m * np.outer(v, v)
    w2, phi = scipy.linalg.eigh(K_mean, M)
    j = _mesh_mode(K_mean, M, v, k_mean_n_per_m)
    wj, pj = math.sqrt(w2[j]), phi[:, j]
    c_struct = float(pj @ C @ pj)
    c_m = max(0.0, (2 * drive.mesh_damping_ratio * wj - c_struct) / float(v @ pj) ** 2)
    return LumpedModel(pair=pair, drive=drive, dofs=dofs, M=M, K_s=K, C_s=C, v=v, ratio=ratio, f_static=f,
                       torque_nm=torque_nm, k_mean_n_per_m=float(k_mean_n_per_m), c_mesh_n_s_per_m=c_m)
