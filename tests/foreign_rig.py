"""A second, independent gear-vibration simulator: the "other simulator" the comparison is checked against.

Nothing here imports gearpit. It is the textbook model a reader of Kahraman & Singh (1990), Parker et al.
(2000) or Chaari et al. (2009) would write in an afternoon, deliberately different from
:mod:`datagen` in every modelling choice the comparison might silently rely on:

=================================  ==========================================  ====================================
                                   gearpit (:mod:`datagen`)                    this module
=================================  ==========================================  ====================================
mesh stiffness                     potential energy per slice (Hertz, bending,  ISO 6336 single stiffness ``c'`` per
                                   shear, compression, fillet)                 pair, a half-sine shape along the path
degrees of freedom                 motor, couplings, both gears (torsion,       relative torsion along the line of
                                   bearings), load                             action + one bearing DOF per gear
time integration                   implicit Newmark / periodic shooting        explicit classical Runge-Kutta (RK4)
                                                                               at 4 fs, FIR-decimated
contact                            compliance per slice, pairs share the load  per-pair ``k_j max(0, delta - e_j)``
eccentricity                       moving centre (``datagen.centre_offset``)   projected transmission error + the
                                                                               path of contact from the changed
                                                                               centre distance (``dL/da = -1/sin a``)
pitch error                        sinusoidal cumulative + one displaced tooth  random single-pitch deviations,
                                                                               cumulated and closed (random walk)
speed fluctuation                  controller set point of the motor          kinematic frequency modulation
torque fluctuation                 load torque through the drive train          the static mesh force follows it
housing path                       SDOF housing driven by the bearing force    base-excited SDOF filter
                                                                               (``scipy.signal.lsim``) on the
                                                                               bearing acceleration
=================================  ==========================================  ====================================

Only the gear geometry is shared (the ``spur-gds`` numbers: 29/100 teeth, module 2 mm, 20 deg, 20 mm face), since
a comparison is always told the pair. Units SI; the sensor is the pinion-bearing acceleration along the line of
action (m/s^2) times ``gain``; a tachometer gives one 5 V pulse per pinion revolution.

References
----------
ISO 6336-1:2019, sec. 9 (single stiffness c' = 14 N/(mm um) for solid steel spur gears; mesh stiffness
    c_gamma = (0.75 eps_alpha + 0.25) c').
Kahraman, A., Singh, R. (1990). Non-linear dynamics of a spur gear pair. J. Sound Vib. 142(1), 49-75.
Randall, R. B. (2011). Vibration-based Condition Monitoring, sec. 2.2 and 5.5 (bearing defect impulses).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import signal

#: gearpit effects that only reshape the mesh harmonics (alike on every tooth): what two simulators' healthy pairs
#: differ by, so a comparison of this rig with gearpit's bare model may claim them without a fault being present
MESH_SHAPE = frozenset({"profile_error", "tip_relief", "transmission_path", "hertz_nonlinear", "backlash"})
#: ISO 6336 single stiffness of a solid steel spur pair, N/m per m of face width (14 N/(mm um))
C_PRIME = 14e9
#: fraction of the path of contact over which a pair takes up (and gives up) its stiffness
RAMP = 0.05


@dataclass(frozen=True)
class ForeignRig:
    """Geometry, drive train and operating point of the foreign rig (SI units)."""

    z1: int = 29
    z2: int = 100
    module_m: float = 2e-3
    pressure_angle_rad: float = math.radians(20.0)
    face_width_m: float = 20e-3
    density_kg_m3: float = 7850.0
    speed_rpm: float = 1000.0            # pinion
    torque_nm: float = 50.0              # pinion
    extra_bearing_mass_kg: tuple = (0.6, 1.5)
    bearing_n_per_m: float = 1.5e8
    bearing_damping_ratio: float = 0.04
    mesh_damping_ratio: float = 0.05
    stiffness_shape: float = 0.45        # pair stiffness k(u) = k' (1 - shape + shape sin(pi u)), u along the path
    fs_hz: float = 20000.0
    duration_s: float = 2.0
    settle_s: float = 0.4                # simulated first and dropped
    gain: float = 2.0                    # sensor sensitivity (unknown to the comparison)
    snr_db: float | None = 30.0
    seed: int = 0
    noise_seed: int | None = None        # seed of the noise and the bearing defect's timing (None: seed)
    # effects (all off by default)
    eccentricity_m: tuple = (0.0, 0.0)   # pinion, wheel (offset of the pitch circle from the axis)
    pitch_fp_m: float = 0.0              # pinion cumulative pitch deviation range F_p (random walk, closed)
    profile_m: float = 0.0               # profile form error amplitude (a "bellied" flank, same on every tooth)
    tip_relief_m: float = 0.0            # linear tip relief on both gears over 20 % of the path at each end
    speed_fluctuation: tuple = (0.0, 0.0)     # (amplitude fraction, Hz)
    torque_fluctuation: tuple = (0.0, 0.0)    # (amplitude fraction, Hz), at the load
    housing: tuple | None = None         # (natural frequency Hz, damping ratio)
    bearing_defect: tuple | None = None  # (defect frequency Hz, ringing Hz, amplitude m/s^2 at the sensor)
    pits: dict = field(default_factory=dict)   # pinion tooth -> (stiffness loss fraction, u0, u1)


def geometry(r: ForeignRig) -> dict:
    """Textbook involute geometry (standard addendum m, no profile shift)."""
    m, a = r.module_m, r.pressure_angle_rad
    rp1, rp2 = m * r.z1 / 2, m * r.z2 / 2
    rb1, rb2 = rp1 * math.cos(a), rp2 * math.cos(a)
    ra1, ra2 = rp1 + m, rp2 + m
    pb = math.pi * m * math.cos(a)
    return {"rp1": rp1, "rp2": rp2, "rb1": rb1, "rb2": rb2, "ra1": ra1, "ra2": ra2, "pb": pb,
            "centre_m": rp1 + rp2, "t1": math.sqrt(ra1 ** 2 - rb1 ** 2), "t2": math.sqrt(ra2 ** 2 - rb2 ** 2)}


def contact_ratio(r: ForeignRig) -> float:
    g = geometry(r)
    return (g["t1"] + g["t2"] - math.sqrt(g["centre_m"] ** 2 - (g["rb1"] + g["rb2"]) ** 2)) / g["pb"]


def _disc_inertia(rho, b, radius):
    mass = rho * math.pi * radius ** 2 * b
    return mass, 0.5 * mass * radius ** 2


def _pitch_deviations(r: ForeignRig) -> np.ndarray:
    """Cumulative pitch deviation of each pinion tooth along the line of action (random walk, closed, range F_p)."""
    if r.pitch_fp_m == 0.0:
        return np.zeros(r.z1)
    rng = np.random.default_rng([r.seed, 7])
    steps = rng.standard_normal(r.z1)
    steps -= steps.mean()                      # the deviations close over the revolution
    cum = np.cumsum(steps)
    cum -= cum.mean()
    return r.pitch_fp_m * cum / np.ptp(cum) * math.cos(r.pressure_angle_rad)


def simulate_foreign(r: ForeignRig) -> dict:
    """Simulate the rig. Returns a dict: ``acc`` (sensor, m/s^2 x gain, with noise), ``tacho`` (V), ``fs_hz``,
    ``pinion_angle_rad`` (the prescribed pinion angle at each sample),
    ``te_m`` (relative rotation along the line of action, rb1 theta1 - rb2 theta2), ``mesh_deflection_m`` (the
    contact's compression, less the eccentricities' error) and ``k_n_per_m`` (the pairs' summed stiffness)."""
    g = geometry(r)
    rb1, rb2, pb = g["rb1"], g["rb2"], g["pb"]
    m1, i1 = _disc_inertia(r.density_kg_m3, r.face_width_m, g["rp1"])
    m2, i2 = _disc_inertia(r.density_kg_m3, r.face_width_m, g["rp2"])
    me = 1.0 / (rb1 ** 2 / i1 + rb2 ** 2 / i2)
    mb1, mb2 = m1 + r.extra_bearing_mass_kg[0], m2 + r.extra_bearing_mass_kg[1]
    kp = C_PRIME * r.face_width_m
    k_mean = contact_ratio(r) * kp * (1 - r.stiffness_shape + r.stiffness_shape * 2 / math.pi)
    cm = 2 * r.mesh_damping_ratio * math.sqrt(k_mean * me)
    cb1 = 2 * r.bearing_damping_ratio * math.sqrt(r.bearing_n_per_m * mb1)
    cb2 = 2 * r.bearing_damping_ratio * math.sqrt(r.bearing_n_per_m * mb2)

    over = 4
    dt = 1.0 / (r.fs_hz * over)
    n_out = int(round((r.duration_s + r.settle_s) * r.fs_hz))
    n = n_out * over
    # every quantity the right-hand side needs, on the half-step grid of RK4
    t = np.arange(2 * n + 1) * (dt / 2)
    w1 = 2 * math.pi * r.speed_rpm / 60
    a_sf, f_sf = r.speed_fluctuation
    phi1 = w1 * t - (a_sf * w1 / (2 * math.pi * f_sf) * np.cos(2 * math.pi * f_sf * t) if a_sf else 0.0)
    phi2 = phi1 * r.z1 / r.z2
    a_tf, f_tf = r.torque_fluctuation
    # the mesh carries the load torque: a fluctuation at the load far below the mesh modes passes through the
    # mesh quasi-statically (the motor's inertia and speed control hold the speed), so the static mesh force
    # T(t) / rb1 follows it. (A first version drove only the wheel with it and held the pinion torque: a free
    # gear set then accelerates as a whole, and only me rb2^2 / I2 = 8 % of the fluctuation reached the mesh.)
    force_static = r.torque_nm / rb1 * (1 + (a_tf * np.sin(2 * math.pi * f_tf * t) if a_tf else 0.0))
    e1, e2 = r.eccentricity_m
    # transmission error of the eccentric centres (their component along the line of action), and the
    # centre distance they change (component along the line of centres)
    te = e1 * np.sin(phi1 + 0.3) + e2 * np.sin(phi2 + 1.1)
    aw = g["centre_m"] + e1 * np.cos(phi1 + 0.3) + e2 * np.cos(phi2 + 1.1)
    s_start = np.sqrt(aw ** 2 - (rb1 + rb2) ** 2) - g["t2"]       # from the pinion's tangent point
    s_end = g["t1"]
    s_start0 = math.sqrt(g["centre_m"] ** 2 - (rb1 + rb2) ** 2) - g["t2"]
    q = rb1 * phi1 / pb
    devs = _pitch_deviations(r)
    # the pairs whose nominal path position lies within one base pitch before the nominal start of contact and
    # the three after it: an eccentric centre that shortens the centre distance starts contact earlier (by up to
    # e / sin(alpha), ~150 um for 50 um), and a window starting at the nominal start left that pair out until it
    # entered the window with up to a third of its stiffness at once, a step whose time the integration grid
    # quantised (a line at fm/2 on the wheel's eccentricity that shrank with the step: -33, -36, -42 dB re the
    # mesh line at fs 20, 40, 80 kHz)
    offsets = (-1, 0, 1, 2)
    n_pairs = len(offsets)
    kk = np.zeros((n_pairs, t.size))
    ee = np.zeros((n_pairs, t.size))
    base = np.floor(q).astype(int)
    for row, j in enumerate(offsets):
        tooth = base - j
        s = s_start0 + (q - tooth) * pb
        on = (s >= s_start) & (s <= s_end)
        u = np.clip((s - s_start) / (s_end - s_start), 0.0, 1.0)
        # a pair takes up its load over the first and last RAMP of the path (the tips' rounding and the
        # teeth's approach under load): a stiffness step would enter at a time quantised to the integration
        # step, and that jitter repeats once per pinion revolution (a mesh period is not a whole number of steps)
        ramp = np.clip(np.minimum(u, 1.0 - u) / RAMP, 0.0, 1.0)
        k = kp * (1 - r.stiffness_shape + r.stiffness_shape * np.sin(np.pi * u)) * ramp
        idx = np.mod(tooth, r.z1)
        for tooth_id, (loss, u0, u1) in r.pits.items():
            k = np.where((idx == tooth_id) & (u >= u0) & (u <= u1), k * (1 - loss), k)
        e = devs[idx] + r.profile_m * (4 * (u - 0.5) ** 2 - 1 / 3)
        if r.tip_relief_m:
            e = e + r.tip_relief_m * (np.clip((u - 0.8) / 0.2, 0, 1) + np.clip((0.2 - u) / 0.2, 0, 1))
        kk[row] = np.where(on, k, 0.0)
        ee[row] = e
    k_total = kk.sum(axis=0)
    d_static = r.torque_nm / rb1 / k_mean
    kb = r.bearing_n_per_m

    # plain Python floats in the loop (numpy scalars are ~10x slower there); per time index: the pairs
    kk, ee = list(zip(*kk.tolist())), list(zip(*ee.tolist()))
    te, force_static = te.tolist(), np.broadcast_to(force_static, t.shape).tolist()

    def rhs(i, p, y1, y2, vp, vy1, vy2):
        d = p + y1 - y2 - te[i]
        f = cm * (vp + vy1 - vy2)
        ki, ei = kk[i], ee[i]
        for j in range(n_pairs):
            k = ki[j]
            if k:
                dj = d - ei[j]
                if dj > 0:
                    f += k * dj
        return (force_static[i] - f) / me, (-kb * y1 - cb1 * vy1 - f) / mb1, (-kb * y2 - cb2 * vy2 + f) / mb2, f

    f0 = r.torque_nm / rb1
    x = [d_static, -f0 / kb, f0 / kb, 0.0, 0.0, 0.0]
    acc = np.empty(n + 1)
    dte = np.empty(n + 1)
    defl = np.empty(n + 1)
    h = dt
    for step in range(n + 1):
        i = 2 * step
        p, y1, y2, vp, vy1, vy2 = x
        a1 = rhs(i, p, y1, y2, vp, vy1, vy2)
        acc[step] = a1[1]
        dte[step] = p
        defl[step] = p + y1 - y2 - te[i]
        if step == n:
            break
        k1 = (vp, vy1, vy2, a1[0], a1[1], a1[2])
        xs = [x[m] + 0.5 * h * k1[m] for m in range(6)]
        a2 = rhs(i + 1, *xs)
        k2 = (xs[3], xs[4], xs[5], a2[0], a2[1], a2[2])
        xs = [x[m] + 0.5 * h * k2[m] for m in range(6)]
        a3 = rhs(i + 1, *xs)
        k3 = (xs[3], xs[4], xs[5], a3[0], a3[1], a3[2])
        xs = [x[m] + h * k3[m] for m in range(6)]
        a4 = rhs(i + 2, *xs)
        k4 = (xs[3], xs[4], xs[5], a4[0], a4[1], a4[2])
        x = [x[m] + h / 6 * (k1[m] + 2 * k2[m] + 2 * k3[m] + k4[m]) for m in range(6)]
    if not np.all(np.isfinite(acc)):
        raise FloatingPointError("foreign rig: the integration diverged")
    y = signal.decimate(acc[:n], over, ftype="fir", zero_phase=True)
    te_out = signal.decimate(dte[:n], over, ftype="fir", zero_phase=True)
    fs = r.fs_hz
    t_out = np.arange(y.size) / fs
    if r.housing is not None:
        fh, zh = r.housing
        wh = 2 * math.pi * fh
        sys_h = signal.lti([2 * zh * wh, wh ** 2], [1, 2 * zh * wh, wh ** 2])   # base excitation, acc -> acc
        _, y, _ = signal.lsim(sys_h, y, t_out)
    if r.bearing_defect is not None:
        fd, fr_hz, amp = r.bearing_defect
        rng = np.random.default_rng([r.seed if r.noise_seed is None else r.noise_seed, 3])
        times = np.arange(0.0, t_out[-1], 1 / fd) + 1e-3 * rng.random()
        ring = np.zeros_like(y)
        for t0 in times:
            tau = t_out - t0
            on = tau >= 0
            ring[on] += amp * np.exp(-tau[on] * 2 * math.pi * fr_hz * 0.05) * np.sin(2 * math.pi * fr_hz * tau[on])
        y = y + ring
    keep = slice(int(round(r.settle_s * fs)), None)
    y = r.gain * y[keep]
    if r.snr_db is not None:
        rng = np.random.default_rng([r.seed if r.noise_seed is None else r.noise_seed, 11])
        y = y + np.std(y) * 10 ** (-r.snr_db / 20) * rng.standard_normal(y.size)
    phi_out = phi1[0:2 * n:2 * over][: t_out.size][keep]
    tacho = np.where(np.mod(phi_out, 2 * math.pi) < 0.1 * 2 * math.pi, 5.0, 0.0)
    return {"acc": y, "tacho": tacho, "fs_hz": fs, "te_m": te_out[keep], "pinion_angle_rad": phi_out,
            "mesh_deflection_m": defl[0:n:over][keep], "k_n_per_m": k_total[0:2 * n:2 * over][keep]}


def foreign_measurement(rig: ForeignRig, *, nominal_speed_rpm: float | None = None):
    """The foreign rig's record as a :class:`compare.measurement.Measurement` (sensor ``acc``, tachometer
    ``tacho``), told what a user would tell it: the pair (``spur-gds``, whose geometry this rig shares), a
    nominal speed 0.5 % off the true one, the torque and fs. The only gearpit import of this module."""
    from compare.measurement import Sidecar, measurement_from_arrays
    from datagen.geometry import preset

    out = simulate_foreign(rig)
    sc = Sidecar(pair=preset("spur-gds"), speed_rpm=nominal_speed_rpm or 1.005 * rig.speed_rpm,
                 torque_nm=rig.torque_nm, fs_hz=out["fs_hz"], sensor="acc", tacho="tacho")
    return measurement_from_arrays({"acc": out["acc"], "tacho": out["tacho"]}, sc, source="foreign simulator")
