"""Whether `nullspace`'s release trials could be decided from the main solve (a design probe for
issue 26's G1 single-support row, not a test; built since as nullspace.py `_predicted_violation`,
whose band sits in the gap this prints).

On one sole the leaving sole's rows stay pinned through the unload, and every tick the active-set
search tries to release each of them: a trial solves the hierarchy again from the row's level down
without it (lab/controller/hierarchy/nullspace.py `_release_one`), about 87 % of a full solve, and
99 % of the trials keep the row. This script runs `lab bench`'s single-support set-up on the
Python kernel and, for every trial of the unload ticks, predicts the trial's violation
C_j z_released − d_j from the main solve alone, then runs the trial as the method does and
compares.

The prediction: releasing row j frees one direction w (C_j w = 1) in the null space of its level's
other pinned rows. The solution as a function of row j's value s is affine, z(s) = z* + (s − d_j) δ,
where δ is w carried down the sub-levels below with each one's least-squares correction
(δ ← δ − Z (M Z)⁺ M δ, the main solve's own matrices). The first sub-level whose residual the
direction moves, g = M δ − M Z (M Z)⁺ M δ ≠ 0, fixes s: s − d_j = −gᵀρ / gᵀg with ρ its residual in
the main solve. Matrix-vector products per sub-level instead of a factorization. Which sub-level
that is, is a rank decision: the script prints the ratio ‖g‖ / (‖M Z‖ max(1, ‖M δ‖)) of the deciding
sub-level and the largest one above it (rounding), to show the gap a threshold must fall in.

    .venv/bin/python benchmarks/release_sensitivity.py [--robot g1] [--ticks 300]

It also prints what the built rule (`_predicted_violation`: its band and margin) decides on the
same trials: how many it finds clear-cut, skips, and predicts to release.
"""

import argparse

import numpy as np

from lab.controller.hierarchy import nullspace
from lab.controller.hierarchy.linalg import least_squares_step
from lab.controller.hierarchy.problem import Level
from lab.experiments.bench import GAITS, HERZOG_PUSH
from lab.world.session import Session, SessionConfig

PUSH_TICK = 1000  # lab bench's push; the leaving sole unloads from here to about tick 1500


def predicted_violation(
    levels: list[Level], active: list[np.ndarray], entry: list, k: int, j: int, threshold: float
) -> tuple[float, float, float]:
    """Row j of level k's violation after its release, predicted from the main solve (module
    doc); with the deciding sub-level's ratio and the largest ratio above it."""
    z, Z = entry[k]
    level, on = levels[k], active[k]
    rest = on.copy()
    rest[j] = False
    Z_pinned, z_pinned = least_squares_step(Z, z, level.C[on], level.d[on])
    Z_rest, z_rest = (
        (Z, z) if not rest.any() else least_squares_step(Z, z, level.C[rest], level.d[rest])
    )
    row, bound = level.C[j], level.d[j]
    if Z_rest.shape[1] == Z_pinned.shape[1]:  # row j depends on the others: nothing is freed
        return float(row @ z_rest - bound), np.inf, 0.0
    w = Z_rest @ (Z_rest.T @ row)
    w -= Z_pinned @ (Z_pinned.T @ w)
    delta = w / (row @ w)
    z, Z = z_pinned, Z_pinned
    below = [(level.A, level.b)] + [
        pair
        for lv, pinned in zip(levels[k + 1 :], active[k + 1 :], strict=True)
        for pair in ((lv.C[pinned], lv.d[pinned]), (lv.A, lv.b))
    ]
    seen = 0.0
    for M, b in below:
        if len(b) == 0:
            continue
        moved, P = M @ delta, M @ Z
        coef = np.linalg.lstsq(P, moved, rcond=None)[0] if Z.shape[1] else np.zeros(0)
        g = moved - P @ coef
        size = max(1.0, float(np.linalg.norm(P, 2)) if P.size else 1.0)
        ratio = float(np.linalg.norm(g)) / (size * max(1.0, float(np.linalg.norm(moved))))
        delta = delta - Z @ coef  # carried on with this sub-level's correction
        if Z.shape[1]:
            Z, z = least_squares_step(Z, z, M, b)
        if ratio > threshold:
            return float(-(g @ (M @ z - b)) / (g @ g)), ratio, seen
        seen = max(seen, ratio)
    return float(row @ z_rest - bound), np.inf, seen


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="g1")
    parser.add_argument("--ticks", type=int, default=300, help="unload ticks from the push on")
    parser.add_argument("--threshold", type=float, default=1e-12, help="ratio deciding a sub-level")
    args = parser.parse_args()
    # predicted, actual, ratio, above, the built rule's prediction (NaN: left to the trial), margin
    trials: list[tuple[float, float, float, float, float, float]] = []

    def release_one(levels, active, z, n, entry, budget):  # nullspace._release_one, recorded
        for k, (level, on) in enumerate(zip(levels, active, strict=True)):
            for j in np.flatnonzero(on):
                guess, ratio, above = predicted_violation(
                    levels, active, entry, k, j, args.threshold
                )
                built = nullspace._predicted_violation(levels, active, entry, k, int(j))
                margin = nullspace.RELEASE_MARGIN * max(1.0, abs(level.d[j]))
                if not budget.take():
                    return None
                on[j] = False
                trial = entry[: k + 1]
                released = nullspace._project(levels, active, n, trial, k, budget)
                actual = float(level.C[j] @ released - level.d[j])
                trials.append(
                    (guess, actual, ratio, above, np.nan if built is None else built, margin)
                )
                if actual <= nullspace.ACTIVATION_TOL:
                    entry[:] = trial
                    return released
                on[j] = True
        return None

    session = Session(SessionConfig(robot=args.robot, method="nullspace", kernel="python"))
    for verb, payload in GAITS["single"].commands:
        session.handle(verb, payload)
    session.handle("hierarchy", {"method": "nullspace", "kernel": "python"})
    force, duration = HERZOG_PUSH
    original = nullspace._release_one
    for tick in range(PUSH_TICK + args.ticks):
        if tick == PUSH_TICK:
            push = {"body": session.robot.base_link, "force": [0.0, force, 0.0]}
            session.handle("push", {**push, "duration": duration})
            nullspace._release_one = release_one
        session.tick()
    nullspace._release_one = original
    guess, actual, ratio, above, built, margin = (
        np.array(column) for column in zip(*trials, strict=True)
    )
    tol = nullspace.ACTIVATION_TOL
    same = int(np.sum((guess > tol) == (actual > tol)))
    error = np.abs(guess - actual) / np.maximum(np.abs(actual), 1e-12)
    decided = np.isfinite(ratio)
    print(f"{args.robot}: {len(trials)} release trials, ticks {PUSH_TICK}-{PUSH_TICK + args.ticks}")
    print(f"  the prediction's decision equals the trial's in {same} of {len(trials)}")
    print(f"  largest relative error of the predicted violation: {error.max():.2g}")
    print(
        f"  smallest violation of a kept row: {actual[actual > tol].min():.3g} (tolerance {tol:g})"
    )
    clear = ~np.isnan(built)
    skipped = clear & (built - tol > margin)
    print(
        f"  the built rule (nullspace._predicted_violation): clear-cut in {np.sum(clear)}, "
        f"skipped {np.sum(skipped)} (released by the trial: {np.sum(skipped & (actual <= tol))})"
        f", predicted releases {np.sum(clear & (tol - built > margin))} (released "
        f"{np.sum(clear & (tol - built > margin) & (actual <= tol))})"
    )
    if decided.any():
        print(
            f"  deciding sub-level's ratio: min {ratio[decided].min():.2g}; largest ratio above it "
            f"(rounding): {above.max():.2g}"
        )


if __name__ == "__main__":
    main()
