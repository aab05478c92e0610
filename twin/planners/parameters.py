"""Every planner parameter in one place: name (the papers' names), default, range, unit.

The scenario, the REST API and the GUI sliders all read ranges and defaults from
`PlannerParameters`; each planner lists which of these fields it uses (`PLANNERS`).
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field


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
    # Seed 002 §5 tunes an effort PID in Gazebo (kp = 5000, ki = 0.5, kd = 10); ours commands
    # velocity, so its gains are those over 625 N·s/m (same kp:ki:kd), with kp·dt < 2 (a stable
    # loop) for every allowed dt (docs/planners_platforms.md).
    kp: float = Field(
        8.0, ge=0.0, le=200.0, description="[1/s] proportional gain of the actuator position loop"
    )
    ki: float = Field(
        8e-4, ge=0.0, le=200.0, description="[1/s²] integral gain of the actuator position loop"
    )
    kd: float = Field(
        0.016, ge=0.0, le=10.0, description="[-] derivative gain of the actuator position loop"
    )
    actuator_speed: float = Field(
        0.1,
        gt=0.0,
        le=2.0,
        description="[m/s] actuator speed limit of the small platforms (seed 002 §5: 0.1)",
    )
