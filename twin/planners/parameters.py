"""Every planner parameter in one place: name (the papers' names), default, range, unit.

The scenario, the REST API and the GUI sliders all read ranges and defaults from
`PlannerParameters`; each planner lists which of these fields it uses (`PLANNERS`).
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from twin.errors import TwinError


class PlannerParameters(BaseModel):
    """Planner knobs with the papers' defaults. Angles a user types are in degrees."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, validate_assignment=True)

    k_e: float = Field(
        25.0,
        ge=0.0,
        le=200.0,
        description="[1/s] closed-loop deviation coefficient k_e (seed 000 eq 34; §5.2: 25)",
    )
    beta: float = Field(
        0.7,
        ge=0.0,
        le=1.0,
        description="[-] parallel/serial weight β (seed 000 eq 28; §5.2: 0.7)",
    )
    l: float = Field(
        1.0, ge=0.0, le=4.0, description="[-] weighting index l (seed 000 eqs 27-30; default 1)"
    )
    k_c: float = Field(
        9.0,
        ge=0.1,
        le=100.0,
        description="[-] telescope weight amplification k_c (seed 000 eq 37; §5.2: 9)",
    )
    sigma: float = Field(
        5.0,
        ge=0.1,
        le=15.0,
        description="[deg] critical protection angle σ of Algorithm 1 (not given; ours)",
    )
    q1_rate_max: float = Field(
        10.0,
        gt=0.0,
        le=45.0,
        description="[deg/s] slew rate limit q̇1,max of Algorithm 1 (not given; ours)",
    )
    yaw_hold: float = Field(
        1.0,
        ge=0.0,
        le=1.0,
        description="[-] what Algorithm 1 leaves the platform's yaw: 1 holds its Euler yaw angle "
        "(w_pz = −tan(roll)·w_py, the reading that reproduces seed 000 Table 7's q1 range), 0 "
        "its body yaw rate (w_pz = 0, as printed), values between blend (docs/decisions.md)",
    )
    k_a2: float = Field(
        1.0,
        ge=0.0,
        le=50.0,
        description="[1/s] gain k_a2 of secondary task 2, q2 held at its start (eqs 34, 39-40)",
    )
    damping: float = Field(
        0.05,
        ge=0.0,
        le=1.0,
        description="[-] damped-least-squares λ_max at a singularity (docs/planners.md)",
    )
    # The qp planner (twin.planners.qp; beyond the papers, docs/planners.md "qp").
    w_orientation: float = Field(
        1.0,
        ge=0.0,
        le=100.0,
        description="[-] qp: weight of the tip orientation (the tip position is met exactly "
        "when the limits allow)",
    )
    w_secondary: float = Field(
        0.1,
        ge=0.0,
        le=1.0,
        description="[-] qp: weight of MTMP's secondary terms (q2 held at its start, the "
        "platform's yaw left to the slew joint)",
    )
    limit_gain: float = Field(
        0.5,
        gt=0.0,
        le=1.0,
        description="[-] qp: velocity-damper gain, the share of its room to a limit a leg or "
        "joint may close in one step",
    )
    qp_damping: float = Field(
        0.01,
        ge=1e-4,
        le=1.0,
        description="[-] qp: regularisation μ of the rates, μ Σ v_j² / w_j with the β split w "
        "(≥ 1e-4 keeps the QP well conditioned for its solver)",
    )
    # Seed 002 §5 tunes an effort PID in Gazebo (kp = 5000, ki = 0.5, kd = 10); ours commands
    # velocity, so kp is a bandwidth: 120 1/s lags the 3 s wave of Table 2 by ω/kp ≈ 1.7 %,
    # the paper's level (η 98.23 %), and ki keeps the paper's ki/kp. The loop is sampled
    # exactly (`twin.planners.gains.proportional_gain`), so it is stable at every dt, and
    # reaches that level at the seed 002 presets' dt = 0.005 s. The paper's kd damps the mass
    # of its effort loop (`actuator_mass` > 0 models that); a velocity loop is first order and
    # needs none: a derivative term rings there once kp·dt nears 1 (docs/planners_platforms.md).
    kp: float = Field(
        120.0,
        ge=0.0,
        le=200.0,
        description="[1/s] bandwidth of the actuator position loop (sampled exactly: stable at "
        "every dt; seed 002 Table 2's level needs kp·dt ≲ 0.6)",
    )
    ki: float = Field(
        0.012, ge=0.0, le=200.0, description="[1/s²] integral gain of the actuator position loop"
    )
    kd: float = Field(
        0.0, ge=0.0, le=10.0, description="[-] derivative gain of the actuator position loop"
    )
    actuator_mass: float = Field(
        0.0,
        ge=0.0,
        le=1000.0,
        description="[kg] moving mass per actuator of the small platforms' effort-driven model "
        "under seed 002's Gazebo PID (kp 5000 N/m, ki 0.5 N/(m·s), kd 10 N·s/m; `pid` only); "
        "0: velocity-commanded actuators (docs/planners_platforms.md)",
    )
    actuator_speed: float = Field(
        0.1,
        gt=0.0,
        le=2.0,
        description="[m/s] actuator speed limit of the small platforms (seed 002 §5: 0.1)",
    )


# ---------------------------------------------------------------------------------------------
# A planner's knobs as the engine's compiled kernels read them: one row per lane, by name.
# ---------------------------------------------------------------------------------------------

#: float64 values in one lane's parameter row (`twin.sim.kernels.layout.N_PARAMETERS` is this)
ROW_SIZE = 64
#: float64 values in one lane's planner state carried from step to step (DWA's shares, a
#: PID's integral, …; `twin.sim.kernels.layout.N_MEMORY` is this)
MEMORY_SIZE = 48

#: Planner families: what a row's `kind` names (the kernel that steps the lane)
KIND_DIFFERENTIAL, KIND_ALLOCATION, KIND_PLATFORM, KIND_QP = 0, 1, 2, 3

#: Fields every family's row starts with: the family (`KIND_*`) and whether the lane holds its
#: joint limits (1.0) or only records passing them (0.0; `Scenario.joint_limits`)
COMMON_FIELDS: tuple[tuple[str, int], ...] = (("kind", 1), ("hold", 1))


#: A record's fields: (name, count) in order, a count of 1 a float64 value, a count > 1 a
#: (count,) float64 array, a record dtype a nested record (`record_dtype`)
RecordFields = tuple[tuple[str, "int | np.dtype"], ...]


def record_dtype(fields: RecordFields, size: int | None = None, what: str = "record") -> np.dtype:
    """A row of float64 values read by name: `fields` (name, count or nested record dtype)
    in order, padded to `size` values (their own number by default), as an `np.record` dtype,
    so a float row (size,) is viewed as one record (`as_record`, `as_records`) and numba's
    kernels read and write the fields by name. Every accumulator, row and block the engine's
    kernels index is one (`family_dtype`, the metrics', records' and diagnostics' rows).

    Raises:
        TwinError: a name repeats, or the fields do not fit `size` values.
    """
    names: list[str] = []
    formats: list[np.dtype] = []
    offsets: list[int] = []
    at = 0
    for name, count in fields:
        if name in names:
            raise TwinError(f"{what}: field {name!r} given twice")
        names.append(name)
        if isinstance(count, np.dtype):  # a nested record of float64 values
            formats.append(count)
            width = count.itemsize // 8
        else:
            formats.append(np.dtype((np.float64, (count,))) if count > 1 else np.dtype(np.float64))
            width = count
        offsets.append(8 * at)
        at += width
    if size is None:
        size = at
    if at > size:
        raise TwinError(f"{what}: {at} values do not fit a row of {size}")
    fields_ = {"names": names, "formats": formats, "offsets": offsets, "itemsize": 8 * size}
    # np.record: a record reads its fields as attributes (`p.gain`) in plain Python too, as
    # numba's records do, so the interpreted engine runs the kernels unchanged
    return np.dtype((np.record, fields_))


def row_size(dtype: np.dtype) -> int:
    """The float64 values of one row of a `record_dtype`."""
    return dtype.itemsize // 8


def as_record(row: np.ndarray, dtype: np.dtype) -> np.record:
    """A float row (row_size(dtype),) seen as one record of `dtype` (`record_dtype`): writing
    a field writes the row."""
    return row.view(dtype)[0]


def as_records(rows: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """Float rows (..., row_size(dtype)) seen as records (...) of `dtype` (`record_dtype`),
    the last axis contiguous: `as_records(diag, HYBRID_DIAGNOSTICS)["weights"]` is a view."""
    return rows.view(dtype)[..., 0]


def family_dtype(fields: tuple[tuple[str, int], ...]) -> np.dtype:
    """A planner family's parameter record (`record_dtype`): `COMMON_FIELDS` then `fields`
    (name, count) as float64 values in order (a count > 1 is a (count,) array field), padded
    to `ROW_SIZE` values, so a lane's float row (ROW_SIZE,) is viewed as one record
    (`parameter_record`) and numba's kernels read the fields by name.

    Raises:
        TwinError: the fields do not fit a row, or a name repeats.
    """
    return record_dtype((*COMMON_FIELDS, *fields), ROW_SIZE, "family_dtype")


#: The fields every family's row starts with (`COMMON_FIELDS`), as the engine reads a row
#: whatever its family: `kind` (`KIND_*`) and `hold`
COMMON_PARAMETERS = family_dtype(())


def parameter_row(kind: int, hold: bool) -> np.ndarray:
    """A new lane row (ROW_SIZE,) of zeros with its common fields set."""
    row = np.zeros(ROW_SIZE)
    common = as_record(row, COMMON_PARAMETERS)
    common.kind, common.hold = kind, 1.0 if hold else 0.0
    return row


def parameter_record(row: np.ndarray, dtype: np.dtype) -> np.record:
    """The lane row (ROW_SIZE,) seen as one record of `dtype` (`family_dtype`): writing a
    field writes the row."""
    return as_record(row, dtype)


def refuse(what: str) -> TwinError:
    """The error of a `pack()` whose part or value the compiled kernels cannot run."""
    return TwinError(f"planner: the compiled kernel cannot run {what}")


def pack_part(part: object, record: np.void, role: str) -> None:
    """`part.pack(record)`: a task, weight or limit writes its fields by name; one without a
    `pack` is refused (TwinError naming it and its `role`)."""
    pack = getattr(part, "pack", None)
    if pack is None:
        raise refuse(f"the {role} {part!r:.80} (it has no pack())")
    pack(record)
