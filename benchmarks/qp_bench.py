"""The `qp` planner per run against the Pinocchio peer (issue 29, item 7), measured in one run.

    python benchmarks/qp_bench.py [--steps 4000] [--repeat 4]

Rows: the peer's closed-loop WPI loop over the reference run's steps (`pinocchio_peer.py`,
inputs as `run.py` builds them), then `simulate()` of 200 s at WMO sea state 4 (the reference
run's sea) with the `qp` planner in `record` and `hold` mode and, for scale, MTMP. Each
simulate() is measured right after a measurement of the peer, best of `--repeat`, and divided
by the best peer time (the machine is shared: only ratios measured side by side mean anything).
Target: every planner ≤ 0.15× the peer per run. Reported, not asserted.
"""

from __future__ import annotations

import argparse

from pinocchio_peer import PinocchioPeer
from run import REFERENCE, best, peer_inputs

from twin.sim import PAPER_PRESETS, simulate

#: issue 29's target: every planner, qp included, per run × the peer's time for as many steps
TARGET = 0.15


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=4000)
    parser.add_argument("--repeat", type=int, default=4)
    args = parser.parse_args()
    duration = args.steps * 0.05
    reference = PAPER_PRESETS[REFERENCE].model_copy(update={"duration": duration})
    runs = {
        "qp": reference.model_copy(update={"planner": "qp"}),
        "qp, joint_limits=hold": reference.model_copy(
            update={"planner": "qp", "joint_limits": "hold"}
        ),
        "MTMP": reference,
    }
    for scenario in runs.values():  # compile or load the kernels first
        simulate(scenario.model_copy(update={"duration": 1.0}))
    targets, twists, q0 = peer_inputs(args.steps)
    peer = PinocchioPeer()
    peer_times: list[float] = []
    times = {label: [] for label in runs}
    for _ in range(args.repeat):
        for label, scenario in runs.items():
            peer_times.append(best(lambda: peer.run(q0, targets, twists, 0.05), 1))
            times[label].append(best(lambda s=scenario: simulate(s), 1))
    t_peer = min(peer_times)
    print("| what | time | target | |")
    print("| --- | --- | --- | --- |")
    print(f"| peer: Pinocchio WPI loop, {args.steps} steps | {t_peer * 1e3:.1f} ms "
          f"({t_peer / args.steps * 1e6:.1f} µs/step) | | |")  # fmt: skip
    for label, measured in times.items():
        ratio = min(measured) / t_peer
        verdict = "met" if ratio <= TARGET else "MISSED"
        print(f"| simulate(), hybrid {label}, WMO 4, {duration:g} s | {min(measured) * 1e3:.1f} ms "
              f"= {ratio:.2f}× peer | ≤ {TARGET}× peer | {verdict} |")  # fmt: skip


if __name__ == "__main__":
    main()
