"""Many scenarios at once: `simulate_many` steps hybrid-system runs together over a batch axis.

Each result equals `simulate(scenario)` to 1e-9 (tested); only the work is arranged otherwise:

- everything that does not feed back — the base motion, the held target ᴮT_d and its twist, and
  what `HybridRig.record` stores (legs, tip error, attitude angles, …) — is computed for whole
  runs at once, vectorised over time;
- only the planner step and the integration run in the time loop, for every scenario of a group
  at once: scenarios group by planner, dt and number of steps.

Engines. PI, WPI and MTMP run the fused step of `twin.sim.batch_kernel`, on numpy lanes or,
when numba is installed, compiled and parallel over scenarios (`engine="numba"`, the default
`"auto"` picks it); both do the same arithmetic. DWA, conv1 and conv2 (position-level, seed
004) step their `AllocationPlanner` on the batch axis. The small platforms (upu3up, upr4) and
zero-step runs are not batched: they run `simulate` one by one.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Iterable, Sequence
from functools import cache
from typing import Any

import numpy as np
from tqdm import tqdm

from twin.errors import TwinError
from twin.mechanisms import HybridBoardingSystem
from twin.mechanisms.legs import LegState, twist_jacobian
from twin.planners import (
    AllocationPlanner,
    BetaSplit,
    DifferentialPlanner,
    JointLimitWeights,
    JointPostureTask,
    ProductWeights,
    TipTarget,
    get_planner,
)
from twin.sim.base_motion import mount_for
from twin.sim.engine import simulate
from twin.sim.faults import series_faults
from twin.sim.metrics import hybrid_metrics
from twin.sim.result import SimulationResult
from twin.sim.scenario import Scenario
from twin.sim.target import tilt
from twin.spatial import invert_transform, pose_error, pose_to_transform, so3_log
from twin.vessel import load_raos
from twin.vessel.motion import response_amplitudes

#: most scenarios stepped together; larger lists run in groups of this size
MAX_LANES = 256
#: samples × scenarios whose targets are prepared at once (bounds memory: BLOCK × 18 floats)
BLOCK = 65_536
#: planners of the fused kernel and of the allocation path
DIFFERENTIAL = frozenset({"pi", "wpi", "mtmp"})
ALLOCATION = frozenset({"dwa", "conv1", "conv2"})
ENGINES = ("auto", "numpy", "numba")


def simulate_many(
    scenarios: Iterable[Scenario | dict], *, progress: bool = False, engine: str = "auto"
) -> list[SimulationResult]:
    """Run many scenarios; the same results as `[simulate(s) for s in scenarios]`, faster.

    Args:
        scenarios: `Scenario`s or dicts of their fields (validated).
        progress: show a tqdm bar over all steps.
        engine: "numpy", "numba" (needs numba installed) or "auto" (numba when installed).

    Returns:
        One `SimulationResult` per scenario, in order.

    Raises:
        ValueError: a bad scenario (naming the field) or an unknown or unavailable engine.
    """
    scenarios = [s if isinstance(s, Scenario) else Scenario(**s) for s in scenarios]
    compiled = _use_numba(engine)
    groups: dict[tuple, list[int]] = defaultdict(list)
    alone: list[int] = []
    for i, s in enumerate(scenarios):
        n_steps = round(s.duration / s.dt)
        # the fused kernel solves with λ > 0 only: an undamped (damping = 0) rank-deficient
        # J_W (β = 0) needs the SVD fallback of `weighted_pinv`, so it runs scenario by scenario
        batchable = (
            s.planner in DIFFERENTIAL | ALLOCATION and s.joint_limits == "record" and s.damping > 0
        )
        if s.mechanism == "hybrid" and n_steps > 0 and batchable:
            groups[(s.planner, s.dt, n_steps)].append(i)
        else:
            alone.append(i)
    results: list[SimulationResult | None] = [None] * len(scenarios)
    total = sum(round(s.duration / s.dt) for s in scenarios)
    with tqdm(total=total, disable=not progress, unit="step", unit_scale=True) as bar:
        for (planner, dt, n_steps), members in groups.items():
            for start in range(0, len(members), MAX_LANES):
                chunk = members[start : start + MAX_LANES]
                batch = _HybridBatch([scenarios[i] for i in chunk], dt, n_steps)
                try:
                    if planner in ALLOCATION:
                        batch.run_allocation(planner, bar)
                    else:
                        batch.run_differential(bar, compiled)
                except _Unbatchable:
                    alone.extend(chunk)
                    continue
                for i, result in zip(chunk, batch.results(), strict=True):
                    results[i] = result
        for i in alone:
            results[i] = simulate(scenarios[i])
            bar.update(round(scenarios[i].duration / scenarios[i].dt))
    return results  # type: ignore[return-value]


def numba_available() -> bool:
    """Whether the compiled engine can run (numba importable)."""
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def _use_numba(engine: str) -> bool:
    if engine not in ENGINES:
        raise TwinError(f"engine: unknown {engine!r}; allowed: {list(ENGINES)}")
    if engine == "numba" and not numba_available():
        raise TwinError("engine: 'numba' needs the numba package (pip install numba)")
    return engine == "numba" or (engine == "auto" and numba_available())


@cache
def _raos(name: str) -> Any:
    """RAO tables by vessel name, read once per process (a NetCDF read per run costs ms)."""
    return load_raos(name)


def uniform_motion(omega_e: np.ndarray, amplitude: np.ndarray, n: int, dt: float) -> np.ndarray:
    """`vessel_motion` at t = k dt, k = 0 … n − 1, (n, 6) [m, rad].

    e^{−iω k dt} = e^{−iω b dt} e^{−iω aB dt} with k = aB + b, so only (A + B) × K complex
    exponentials are evaluated instead of n × K, and the real part of the sum is A real matrix
    products (B, 2K) @ (2K, 6). Stacked, not one large product: a multi-threaded BLAS call
    on a busy machine costs ten times more than the arithmetic.
    """
    fine = math.isqrt(max(n - 1, 0)) + 1  # B
    coarse = -(-n // fine)  # A
    e_fine = np.exp(-1j * np.outer(np.arange(fine) * dt, omega_e))  # (B, K)
    e_coarse = np.exp(-1j * np.outer(np.arange(coarse) * (fine * dt), omega_e))  # (A, K)
    X = e_coarse[:, :, None] * amplitude  # (A, K, 6)
    lhs = np.concatenate([e_fine.real, -e_fine.imag], 1)  # (B, 2K)
    return (lhs @ np.concatenate([X.real, X.imag], 1)).reshape(-1, 6)[:n]


def base_poses(scenario: Scenario, n: int) -> np.ndarray:
    """The base's inertial poses (n, 6) at t = k dt, as `BaseMotion(...).sample` gives them."""
    mount = mount_for(scenario.mechanism)
    raos = _raos(scenario.vessel or mount.vessel)
    omega_e, amplitude = response_amplitudes(
        scenario.components(), raos, 0.0, scenario.forward_speed
    )
    return mount.pose(uniform_motion(omega_e, amplitude, n, scenario.dt))


def pack_planner(planner: DifferentialPlanner, n: int = 9) -> tuple[np.ndarray, tuple] | None:
    """A `DifferentialPlanner` as the fused kernel's parameter row and flags.

    Returns:
        (prm (N_PARAMETERS,), (joint_limits, posture, slew)), or None when the planner has a
        part the kernel does not implement (it then runs on its own).
    """
    from twin.sim import batch_kernel as bk

    prm = np.zeros(bk.N_PARAMETERS)
    parts = planner.weights.parts if isinstance(planner.weights, ProductWeights) else ()
    split = [p for p in (planner.weights, *parts) if isinstance(p, BetaSplit)]
    limits = [p for p in parts if isinstance(p, JointLimitWeights)]
    known = planner.weights is None or (split and len(split) + len(limits) == max(len(parts), 1))
    secondary = planner.secondary
    if (
        not known
        or len(secondary) > 1
        or any(not isinstance(task, JointPostureTask) or task.n != n for task in secondary)
        or planner.velocity_limit is None
        or (planner.slew_priority is not None and planner.slew_priority.yaw_index != 5)
        or (planner.slew_priority is not None and planner.slew_priority.slew_index != 6)
    ):
        return None
    prm[bk.P_GAIN] = planner.tip.gain
    prm[bk.P_SPLIT : bk.P_SPLIT + n] = split[0](np.zeros(n)) if split else 1.0
    prm[bk.P_SCALE : bk.P_SCALE + n] = limits[0].scale if limits else 1.0
    posture = -1
    if secondary:
        posture = secondary[0].index
        prm[bk.P_POSTURE_GAIN], prm[bk.P_POSTURE_SET] = secondary[0].gain, secondary[0].setpoint
    slew = planner.slew_priority
    if slew is not None:
        prm[bk.P_SIGMA], prm[bk.P_SLEW_RATE] = slew.sigma, slew.rate_max
        prm[bk.P_Q1_MIN], prm[bk.P_Q1_MAX] = slew.q1_min, slew.q1_max
    prm[bk.P_DAMPING], prm[bk.P_EPSILON] = planner.damping_max, planner.epsilon
    prm[bk.P_SECONDARY] = planner.secondary_weight
    return prm, (bool(limits), posture, slew is not None)


def mechanism_constants(mechanism: HybridBoardingSystem, rate_limit: np.ndarray) -> np.ndarray:
    """The fused kernel's `const` row: joint limits, rate limits, gangway d1 and a1."""
    from twin.sim import batch_kernel as bk

    const = np.zeros(bk.N_CONSTANTS)
    const[bk.C_LOWER : bk.C_LOWER + 9] = mechanism.lower
    const[bk.C_UPPER : bk.C_UPPER + 9] = mechanism.upper
    const[bk.C_RATE : bk.C_RATE + 9] = rate_limit
    const[bk.C_D1], const[bk.C_A1] = mechanism.gangway.d1, mechanism.gangway.a1
    return const


class _HybridBatch:
    """N hybrid-system scenarios with the same dt and number of steps, lane n = scenario n."""

    def __init__(self, scenarios: Sequence[Scenario], dt: float, n_steps: int) -> None:
        self.scenarios = list(scenarios)
        self.dt, self.n_steps = dt, n_steps
        self.mechanism = HybridBoardingSystem()
        self.xi0 = np.stack(
            [
                self.mechanism.working_state if s.initial_state is None else s.initial_state
                for s in self.scenarios
            ]
        ).astype(float)  # (N, 9)
        self.poses = np.stack([base_poses(s, n_steps + 1) for s in self.scenarios])  # (N, n+1, 6)
        T_IB0 = pose_to_transform(self.poses[:, 0])
        self.held = T_IB0 @ self.mechanism.end_effector(self.xi0)  # ᴵT_E*, HybridRig.reset
        self.xi = np.empty((len(self.scenarios), n_steps + 1, 9))  # filled by a run_* method
        self.diagnostics: dict[str, np.ndarray] = {}  # name → (N, n_steps, ...)
        self.faults = np.zeros(len(self.scenarios), dtype=int)

    def targets(self, k0: int, k1: int) -> np.ndarray:
        """`held_target` for samples k0 … k1 − 1, (N, k1 − k0, 18): ᴮR_d row-major, ᴮp_d, twist."""
        T_IB = pose_to_transform(self.poses[:, k0 : k1 + 1])
        T = invert_transform(T_IB) @ self.held[:, None]  # ᴮT_d = ᴵT_B⁻¹ ᴵT*
        R0, R1 = T[:, :-1, :3, :3], T[:, 1:, :3, :3]
        v = (T[:, 1:, :3, 3] - T[:, :-1, :3, 3]) / self.dt
        w = so3_log(R1 @ np.swapaxes(R0, -1, -2)) / self.dt
        return np.concatenate([R0.reshape(*R0.shape[:2], 9), T[:, :-1, :3, 3], v, w], -1)

    def run_differential(self, bar: tqdm, compiled: bool) -> None:
        """PI / WPI / MTMP through the fused kernel; a scenario it cannot express runs alone."""
        from twin.sim import batch_kernel as bk

        planners = [
            get_planner(s.planner, "hybrid").build(self.mechanism, s.parameters(), xi0)
            for s, xi0 in zip(self.scenarios, self.xi0, strict=True)
        ]
        packed = [pack_planner(p) for p in planners]
        if any(p is None for p in packed) or len({p[1] for p in packed}) > 1:
            raise _Unbatchable
        rate = planners[0].velocity_limit.maximum
        if any(not np.array_equal(p.velocity_limit.maximum, rate) for p in planners):
            raise _Unbatchable
        prm = np.stack([p[0] for p in packed])  # (N, P)
        joint_limits, posture, slew = packed[0][1]
        const = mechanism_constants(self.mechanism, rate)
        N = len(self.scenarios)
        diag = np.empty((N, self.n_steps, bk.N_DIAGNOSTICS))
        self.xi[:, 0] = self.xi0
        args = (const, self.dt, joint_limits, posture, slew)
        if compiled:
            import numba

            # threads pay off only with several scenarios each; a Dask worker sets one thread
            run = bk.compiled_runner(numba.get_num_threads() > 1 and N > 1)
            for k0, k1 in self._blocks():
                run(self.xi[:, k0 : k1 + 1], self.targets(k0, k1), prm, *args, diag[:, k0:k1])
                bar.update((k1 - k0) * N)
        else:
            lanes = (N,)
            scratch = (bk.constant_k(lanes), np.empty((6, 6, *lanes)), np.empty((6, 6, *lanes)))
            w = np.empty((9, N))
            xs = np.empty((self.n_steps + 1, 9, N))  # component-major: xs[k, i] is a lane
            out = np.empty((self.n_steps, bk.N_DIAGNOSTICS, N))
            xs[0] = self.xi0.T
            prm_lanes = np.ascontiguousarray(prm.T)
            with np.errstate(all="ignore"):  # the damping test takes √ of negative pivots
                for k0, k1 in self._blocks():
                    target = np.ascontiguousarray(self.targets(k0, k1).transpose(1, 2, 0))
                    for k in range(k0, k1):
                        bk.step(xs[k], target[k - k0], prm_lanes, *args, *scratch, w, xs[k + 1],
                                out[k])  # fmt: skip
                    bar.update((k1 - k0) * N)
            self.xi[:] = xs.transpose(2, 0, 1)
            diag[:] = out.transpose(2, 0, 1)
        self.faults = np.sum(diag[:, :, bk.D_FAULT], axis=1).astype(int)
        self.diagnostics = {
            "weights": diag[:, :, bk.D_WEIGHTS : bk.D_WEIGHTS + 9],
            "null_space_share": diag[:, :, bk.D_SHARE],
            "damping": diag[:, :, bk.D_DAMPING],
            "velocity_scale": diag[:, :, bk.D_SCALE],
        }

    def run_allocation(self, method: str, bar: tqdm) -> None:
        """DWA / conv1 / conv2: their `AllocationPlanner` on the batch axis, as HybridRig steps."""
        N = len(self.scenarios)
        planner = AllocationPlanner(self.mechanism, method)
        xi = self.xi0.copy()
        self.xi[:, 0] = xi
        share = np.empty((N, self.n_steps, 3))
        for k0, k1 in self._blocks():
            target = self.targets(k0, k1)
            R = target[..., :9].reshape(N, -1, 3, 3)
            T = np.zeros((N, k1 - k0, 4, 4))
            T[..., :3, :3], T[..., :3, 3], T[..., 3, 3] = R, target[..., 9:12], 1.0
            if k0 == 0:
                planner.reset(xi, TipTarget(T[:, 0], target[:, 0, 12:]))
            for k in range(k0, k1):
                out = planner.step(xi, TipTarget(T[:, k - k0], target[:, k - k0, 12:]), self.dt)
                v = out.velocity
                bad = ~np.all(np.isfinite(v), axis=-1)  # HybridRig: a fault holds still
                v = np.where(bad[:, None], 0.0, v)
                self.faults += bad
                xi = self.mechanism.integrate(xi, v, self.dt)
                self.xi[:, k + 1] = xi
                share[:, k] = out.diagnostics["position_share"]
            bar.update((k1 - k0) * N)
        self.diagnostics = {"position_share": share}

    def _blocks(self) -> Iterable[tuple[int, int]]:
        steps = max(1, BLOCK // len(self.scenarios))
        for k0 in range(0, self.n_steps, steps):
            yield k0, min(k0 + steps, self.n_steps)

    def results(self) -> list[SimulationResult]:
        """One result per scenario: the series `HybridRig.record` would have stored, metrics."""
        t = np.arange(self.n_steps + 1) * self.dt
        out = []
        for n, s in enumerate(self.scenarios):
            records = hybrid_records(self.mechanism, self.poses[n], self.xi[n], self.held[n])
            series = {"t": t, **records}
            for name, values in self.diagnostics.items():
                # no step has been taken at t = 0: the first step's values repeat there
                series[name] = np.concatenate([values[n, :1], values[n]])
            series["limit_scale"] = np.ones(self.n_steps + 1)  # "record" takes every step
            metrics = hybrid_metrics(series, self.mechanism)
            metrics["faults"] = int(self.faults[n])
            metrics["fault_counts"] = {
                "base_motion": 0,  # the batch's sea is finite by construction (no injection)
                "planner": int(self.faults[n]),
                "kinematics": 0,
                **series_faults(series),
            }
            out.append(SimulationResult(s, series, metrics))
        return out


class _Unbatchable(Exception):
    """A group the fused kernel cannot express; `simulate_many` runs it scenario by scenario."""


def hybrid_records(
    mechanism: HybridBoardingSystem, poses: np.ndarray, xi: np.ndarray, held: np.ndarray
) -> dict[str, np.ndarray]:
    """`HybridRig.record` for a whole run at once (each transform computed once, not per use).

    Args:
        mechanism: the hybrid system.
        poses: (T, 6) inertial base poses [m, rad].
        xi: (T, 9) virtual joints [m, rad].
        held: (4, 4) ᴵT_E*, the held tip pose.

    Returns:
        base_pose, xi, legs, tip_error, manipulability, phi_e, theta_e, alpha_top, alpha_bottom,
        each (T, ...).
    """
    T_IB = pose_to_transform(poses)
    T_P = pose_to_transform(xi[:, :6])
    # ᴾT_E of Table 2 in closed form (as twin.sim.batch_kernel): Gangway.links builds and
    # multiplies three 4×4 DH matrices per sample
    s1, c1 = np.sin(xi[:, 6]), np.cos(xi[:, 6])
    s2, c2 = np.sin(xi[:, 7] + np.pi / 2), np.cos(xi[:, 7] + np.pi / 2)
    d3, gangway = xi[:, 8], mechanism.gangway
    G = np.zeros((len(xi), 4, 4))
    G[:, 0, :] = np.stack([c1 * c2, s1, c1 * s2, c1 * (gangway.a1 + d3 * s2)], -1)
    G[:, 1, :] = np.stack([s1 * c2, -c1, s1 * s2, s1 * (gangway.a1 + d3 * s2)], -1)
    G[:, 2, :] = np.stack([s2, np.zeros_like(s2), -c2, gangway.d1 - d3 * c2], -1)
    G[:, 3, 3] = 1.0
    T_E = T_P @ G  # HybridBoardingSystem.end_effector
    R_IP = T_IB[:, :3, :3] @ T_P[:, :3, :3]
    g = (R_IP @ (d3[:, None] * G[:, :3, 2])[:, :, None])[:, :, 0]  # luff pivot → tip, inertial
    # landing frame: inertial, x along the initial horizontal gangway direction (seed 004)
    heading = np.arctan2(g[0, 1], g[0, 0])
    c, s = np.cos(heading), np.sin(heading)
    g = g @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    up0 = held[:3, 0]  # the tip's x axis is "up" at q = 0
    up = (T_IB[:, :3, :3] @ T_E[:, :3, 0:1])[:, :, 0]
    # StewartPlatform.legs and .manipulability, the arms as one (6, 3) @ (3, 3) per sample
    layout = mechanism.layout
    arms = layout.platform_hinges @ np.swapaxes(T_P[:, :3, :3], -1, -2)
    vectors = arms + T_P[:, None, :3, 3] - layout.base_hinges
    lengths = np.linalg.norm(vectors, axis=-1)
    J = twist_jacobian(LegState(vectors, lengths, vectors / lengths[..., None], arms))
    return {
        "base_pose": poses,
        "xi": xi,
        "legs": lengths,
        "tip_error": pose_error(invert_transform(T_IB) @ held, T_E),
        "manipulability": np.sqrt(np.abs(np.linalg.det(J @ np.swapaxes(J, -1, -2)))),
        "phi_e": np.arctan2(g[:, 1], g[:, 0]) - np.arctan2(g[0, 1], g[0, 0]),
        "theta_e": np.arctan2(g[:, 2], g[:, 0]) - np.arctan2(g[0, 2], g[0, 0]),
        "alpha_top": np.arctan2(np.linalg.norm(np.cross(up, up0), axis=-1), up @ up0),
        "alpha_bottom": tilt(T_IB[:, :3, :3]),
    }
