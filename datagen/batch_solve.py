"""The cases of one simulation call prepared for the dynamics and solved, within a memory budget.

:func:`datagen.simulate.simulate` (the orchestrator) calls :func:`prepare_and_solve`, then runs the output hooks
on the responses. Here:

- :func:`prepare`: the stages before the time loop, pit map (:mod:`datagen.pits`) -> mesh stiffness
  (:mod:`datagen.stiffness`) -> effect hooks 1-2 (:mod:`datagen.mesh_excitation`; a time-stepped case's record
  holds only the mesh cycles it rolls through, :func:`cycles_rolled`) -> lumped model (:mod:`datagen.lumped_model`);
- :func:`solver_channels`: the solver channels the output channels asked for are made of;
- :func:`prepare_and_solve`: every case prepared and solved (:func:`datagen.dynamics.solve`), the time-stepped
  ones in parts when their mesh records together pass :data:`RECORD_BUDGET_BYTES`.

:mod:`datagen.simulate` re-exports :func:`prepare`, :func:`case_dofs`, :func:`cycles_rolled` and
:func:`solver_channels`; patch them, and the constants, here, where they are read.
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from datagen import dynamics
from datagen.lumped_model import HELICAL_DOFS, SPUR_DOFS, build_model
from datagen.case_options import auto_positions_per_cycle
from datagen.mesh_excitation import mesh_record

if TYPE_CHECKING:
    from datagen.simulate import Case


def prepare(case: Case) -> dynamics.DynamicCase:
    """Stages before the time loop: pits, stiffness, effect hooks 1-2, lumped model."""
    from datagen.stiffness import mesh_stiffness

    so = case.stiffness
    ppc = so.positions_per_cycle or auto_positions_per_cycle(
        case.fs_hz, case.pair.mesh_frequency_hz(case.operating.speed_rpm))
    ms = mesh_stiffness(case.pair, pits=case.pit_map(), positions_per_cycle=ppc,
                        n_slices=so.n_slices, pit_model=so.pit_model, edges=so.edges)
    ctx = case.context(case_dofs(case))
    rec = mesh_record(ms, case.effects, ctx, keep_slots=any(e.is_nonlinear for e in case.effects),
                      cycles_needed=cycles_rolled(case, ctx))
    model = build_model(case.pair, case.drivetrain, k_mean_n_per_m=rec.mean_k_n_per_m,
                        torque_nm=case.operating.torque_nm)
    return dynamics.DynamicCase(model=model, record=rec, effects=case.effects, ctx=ctx,
                                speed_rpm=case.operating.speed_rpm, torque_nm=case.operating.torque_nm,
                                fs_hz=case.fs_hz, duration_s=case.duration_s,
                                omega_dt=case.solver.step_for(case.effects), method=case.solver.method,
                                transient_s=case.solver.transient_s,
                                mesh_angle=case.solver.mesh_angle, step_limit=case.solver.step_limit)


def case_dofs(case: Case) -> tuple:
    """The lumped model's degrees of freedom for ``case``'s pair (a helical pair adds the axial ones)."""
    return HELICAL_DOFS if case.pair.is_helical else SPUR_DOFS


#: :func:`cycles_rolled`: the mesh cycles of a time-stepped run's reference angle (its speed integrated, speed
#: fluctuations included), times this (the pinion's dynamic angle and the integration's sampling), plus
#: ROLL_SPARE_CYCLES
ROLL_FACTOR = 1.1
ROLL_SPARE_CYCLES = 4
#: time points per second (at least 4096 in all) on which cycles_rolled integrates a fluctuating speed
ROLL_POINTS_PER_S = 20000


def cycles_rolled(case: Case, ctx=None) -> int | None:
    """The mesh cycles a time-stepped case rolls through (its start-up and its record, with the margins
    :data:`ROLL_FACTOR`, :data:`ROLL_SPARE_CYCLES`), so that its mesh record need hold no more
    (:func:`datagen.mesh_excitation.mesh_record`); None when it may run on the periodic path, or its start-up is
    not given (:attr:`datagen.dynamics.DynamicCase.discard_s` then rounds it to whole record periods).

    An effect that moves the operating point (a speed fluctuation: up to 20 % for a while at a low frequency)
    changes the cycles: the speed is then integrated as the time loop does (trapezoids, on
    :data:`ROLL_POINTS_PER_S`; ``ctx``: the case's effect context, made if not given)."""
    so = case.solver
    stepped = so.method == "transient" or any(e.is_nonlinear or e.is_nonstationary for e in case.effects)
    if not stepped or so.transient_s is None:
        return None
    seconds = float(so.transient_s) + float(case.duration_s) + 2.0 / float(case.fs_hz)
    cycles = seconds * case.pair.mesh_frequency_hz(case.operating.speed_rpm)
    op_fx = [e for e in case.effects if "operating_point" in e.hooks()]
    if op_fx:
        if ctx is None:
            ctx = case.context(case_dofs(case))
        t = np.linspace(0.0, seconds, max(4096, int(ROLL_POINTS_PER_S * seconds)))
        speed = np.full(t.size, float(case.operating.speed_rpm))
        torque = np.full(t.size, float(case.operating.torque_nm))
        for e in op_fx:
            speed, torque = e.operating_point(t, speed, torque, ctx)
        speed = np.abs(np.broadcast_to(np.asarray(speed, float), t.shape))
        turns = float(np.sum(0.5 * (speed[1:] + speed[:-1]) * np.diff(t))) / 60.0
        cycles = max(cycles, turns * case.pair.pinion.teeth)
    return int(math.ceil(ROLL_FACTOR * cycles)) + ROLL_SPARE_CYCLES


def solver_channels(effects, wanted) -> frozenset | None:
    """The solver channels that make the output channels ``wanted`` through the output hooks of ``effects``
    (applied in order: every ``output_path``, then every ``measurement``; walked back from the last), by each
    effect's :meth:`Effect.channels_read`; None (every channel) when ``wanted`` is None or an effect reads all."""
    if wanted is None:
        return None
    need = frozenset(wanted)
    chain = ([e for e in effects if "output_path" in e.hooks()] + [e for e in effects if "measurement" in e.hooks()])
    for e in reversed(chain):
        need = e.channels_read(need)
        if need is None:
            return None
    return frozenset(need)


#: solver channel the plausibility checks read (:func:`datagen.plausibility.record_warnings`); made even when the
#: caller asks for others (each channel is the same to the bit whatever else is made; ~3 % more time on a shard of
#: 0.5 s records at 4096 Hz, two more channels cost 14 %)
CHECKED_CHANNELS = frozenset({"mesh_force_n"})

#: mesh records (bytes) a batch of time-stepped cases may hold at once (:func:`prepare_and_solve`)
RECORD_BUDGET_BYTES = 1.5e9


def _record_bytes(rec) -> int:
    return rec.k.nbytes + rec.error_force.nbytes + rec.k_slots.nbytes + rec.e_slots.nbytes


def prepare_and_solve(cases: list, channels) -> tuple[list, list]:
    """Prepare every case and solve it. Time-stepped cases are solved as soon as their mesh records reach
    :data:`RECORD_BUDGET_BYTES` together, and their records dropped; the rest (and the periodic cases, whose
    batch shares its steps per cycle) in one call at the end. A time-stepped case's response does not depend on
    the other cases of its batch (each has its own state, record and Newton iterations), so the split changes
    nothing but the memory: the accelerations to the bit, the wheel speed by a rounding
    (``tests/test_dynamics_simulate.py``; a mix of mesh laws that the compiled loop cannot take together runs
    the numpy loop, the same to 1e-9 of the RMS). Below the budget nothing changes: every case in one call. Why: with errors on both gears a record spans
    the hunting period (spur-gds, 2900 mesh cycles; 0.5 GB at 2048 points per cycle), and the time-stepped fits
    of one comparison with a wheel eccentricity in the model prepared a batch of such cases together: 15.6 GB,
    killed by the kernel on a 24 GB machine (``experiments/foreign_rig_check.py``, stop 43)."""
    n = len(cases)
    prepared, responses = [None] * n, [None] * n
    held, held_bytes = [], 0

    def flush():
        for j, r in zip(held, dynamics.solve([prepared[j] for j in held])):
            responses[j] = r
            prepared[j] = replace(prepared[j], record=None)      # its memory is free; the output needs no record
        held.clear()

    for i, c in enumerate(cases):
        dc = prepare(c)
        if channels is not None:
            need = solver_channels(c.effects, channels)
            dc = replace(dc, channels=None if need is None else need | CHECKED_CHANNELS)
        prepared[i] = dc
        if dc.chosen_method() == "transient":
            held.append(i)
            held_bytes += _record_bytes(dc.record)
            if held_bytes > RECORD_BUDGET_BYTES:
                flush()
                held_bytes = 0
    rest = [i for i in range(n) if responses[i] is None]
    for j, r in zip(rest, dynamics.solve([prepared[j] for j in rest]) if rest else ()):
        responses[j] = r
    return prepared, responses
