"""The native kernel side by side with TSID 1.10 (InverseDynamicsFormulationAccForce + eiquadprog).

A benchmark, not a test, and not in CI. It feeds TSID and the lab's native kernel (`weighted`
method) the same weighted task set on the same states for ANYmal and Talos, checks that the
answers agree, and prints the per-tick times back to back and ours/TSID of the medians.

    .venv/bin/python benchmarks/bench_tsid.py            # makes build/tsid-venv on first use

Over 400 lines: both sides of one comparison (the TSID venv, the worker that poses the problem to
TSID, our side of it, the check that the answers agree), which share the problem's description.

Two processes, because TSID 1.10's bindings are built against pinocchio 4.0.0 and the lab runs
4.1: this script runs in the lab's venv (states, our kernel, the report) and starts itself again
as a worker (`--worker`) in a separate venv holding TSID, talking JSON lines over a pipe. Timing
alternates between the two in blocks, so the machine's load falls on both alike.

The TSID venv (`ensure_tsid_venv`): the PyPI wheel `tsid-1.10.0` (cp311, the bindings) needs
`libtsid==1.10.0`, which PyPI has as an sdist and as cp314 wheels only. libtsid.so is a plain C++
library (it links pinocchio, eiquadprog and boost, not libpython), so by default the script
takes the upstream cp314 wheel and retags it py3-none (`wheel tags`): the same binary, built on
2026-05-21 against libpinocchio 4.0.0 (built the same day), which the constraint file pins.
`--from-source` builds libtsid from its sdist instead (CMake; over an hour on a loaded 2-core
machine).

The same problem on both sides:
- x = [q̈, F], the Newton–Euler rows of the base exact, all feet in support, one weighted QP.
- Tasks with the robot's gains: contact (kp 0, kd of `gains.contact`), CoM, base orientation
  (TaskSE3Equality on the free-flyer's frame, angular mask, world-aligned), posture, force
  regularization F → 0 (TSID's weight vector set to ones). Weights: TSID's are 10× ours, because
  TSID adds 1e-8·I to the Hessian and the lab 1e-9·I: the two QPs are then the same up to a
  factor 10.
- Friction: the lab's inner pyramid |f_t| ≤ (√2/2) μ f_n is TSID's pyramid with μ_TSID = μ/√2
  (TSID's ContactPoint has |f_t| ≤ μ f_n on the tangents n × x, n × (n × x)); point-foot forces in
  world axes (ContactPoint.useLocalFrame(False)), as the lab's.
- Talos's soles differ in form: the lab's F holds the sole wrench (6) with the pyramid on the
  total force and the CoP rectangle (`cop`); TSID's Contact6d holds the four corner forces (12),
  each in its pyramid, wrench = G f. TSID's set is the lab's one with torsion and coupling rows
  added, so the answers are the same where no such row binds; the Hessian regularization then
  still differs (1e-8 on the 12 corner forces, against 1e-8 on the 6 wrench components). The
  comparison uses the wrench G f and reports which rows bind on each side. Every task weight
  is 1000× the robot's on both sides for Talos (`WEIGHT_SCALE`): the same optimum, with the
  regularizations' share of it 1000× smaller (it falls as 1/scale: 1.3e-5 → 1.3e-8 on F).
- The CoM rows: both sides have the drift J̇_com v. (This bench found that the lab's did not:
  its model update read data.acom after pinocchio's computeAllTerms, which leaves it at zero;
  fixed on 2026-12-02 in both kernels.)
- Timed per tick on both sides from Python, cycling through the states: TSID's three
  setReference, computeProblemData, solve and getActuatorForces; ours the references and the
  NativeController's `compute(q, v)` (update, rows, solve and τ in one crossing into the kernel,
  the call a session's tick makes; until 2026-12-04 `update` then `solve`, two crossings), and
  the kernel's own time inside that.
"""

import argparse
import copy
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_VENV = ROOT / "build" / "tsid-venv"
ROBOTS = ("anymal", "talos")
TASKS = ("contact", "com", "base_orientation", "posture", "forces")
CONSTRAINTS = {"anymal": ("friction",), "talos": ("friction", "cop")}
TSID_WEIGHT_SCALE = 10.0  # TSID's Hessian regularization (1e-8) over the lab's weighted one (1e-9)
# Every task weight times this on both sides: Talos's regularizations differ in form (12 corner
# forces, 6 wrench components), and their share of the answer falls as 1/scale.
WEIGHT_SCALE = {"anymal": 1.0, "talos": 1e3}
PUSH_FRACTION_OF_WEIGHT = 0.1  # lateral push on the base for 0.1 s, as lab bench pushes
AGREEMENT = 1e-6  # |ours − TSID| ≤ AGREEMENT (1 + |TSID|), per component
CONSTRAINTS_TXT = "pin==4.0.0\nlibpinocchio==4.0.0\nlibtsid==1.10.0\n"
LIBTSID_CP314 = "libtsid-1.10.0-0-cp314-cp314-manylinux_2_28_x86_64.whl"
LIBTSID_PY3 = "libtsid-1.10.0-0-py3-none-manylinux_2_28_x86_64.whl"


# ------------------------------------------------------------------------------ the TSID venv
def ensure_tsid_venv(venv: Path, from_source: bool) -> Path:
    """The TSID venv's python, making the venv first when it has no `tsid` (module docstring)."""
    python = venv / "bin" / "python"
    if python.exists() and _run([python, "-c", "import tsid"], check=False).returncode == 0:
        return python
    print(f"bench_tsid: making the TSID venv in {venv} (pin 4.0.0, tsid 1.10.0)", flush=True)
    _run([sys.executable, "-m", "venv", str(venv)])
    pip = [str(python), "-m", "pip"]
    work = venv / "downloads"
    work.mkdir(exist_ok=True)
    constraints = work / "constraints.txt"
    constraints.write_text(CONSTRAINTS_TXT)
    if from_source:  # libtsid from its sdist: CMake against the cmeel wheels of pin 4.0.0
        env = dict(os.environ, CMAKE_BUILD_PARALLEL_LEVEL="1", MAKEFLAGS="-j1")
        _run(["nice", "-n", "19", *pip, "install", "-c", str(constraints), "tsid==1.10.0"], env=env)
        return python
    _run([*pip, "install", "wheel"])
    _run(
        [
            *pip,
            "download",
            "libtsid==1.10.0",
            "--no-deps",
            "--only-binary",
            ":all:",
            "--python-version",
            "3.14",
            "--platform",
            "manylinux_2_28_x86_64",
            "-d",
            str(work),
        ]
    )
    _run(
        [
            str(python),
            "-m",
            "wheel",
            "tags",
            "--python-tag",
            "py3",
            "--abi-tag",
            "none",
            "--remove",
            str(work / LIBTSID_CP314),
        ]
    )
    _run([*pip, "install", "-c", str(constraints), str(work / LIBTSID_PY3), "tsid==1.10.0"])
    return python


def _run(command: list, check: bool = True, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([str(c) for c in command], check=check, env=env, capture_output=not check)


# ------------------------------------------------------------------------------ the lab side
def record_states(robot: str, n_standing: int, n_pushed: int) -> dict:
    """States (q, v) and the balance references of a lab session on `robot`: standing, then
    during and after a lateral push (the default stack and kernel run the robot)."""
    from lab.world.session import Session, SessionConfig

    session = Session(SessionConfig(robot=robot))
    weight = session.model.mass * 9.81
    records: list[tuple] = []

    def run(seconds: float, count: int) -> None:
        ticks = round(seconds / session.config.timestep)
        every = max(ticks // count, 1)
        for i in range(ticks):
            session.tick()
            if (i + 1) % every == 0 and len(records) < n_standing + n_pushed:
                refs = session.controller.references
                records.append(
                    (session.model.q.copy(), session.model.v.copy(), copy.deepcopy(refs))
                )

    run(0.5, n_standing)
    push = {"body": session.robot.base_link, "force": [0.0, PUSH_FRACTION_OF_WEIGHT * weight, 0.0]}
    session.handle("push", {**push, "duration": 0.1})
    run(0.3, n_pushed)
    assert not session.fell, f"{robot} fell while the states were recorded"
    return {"session": session, "states": records}


def our_controller(session: object, robot: str) -> object:
    """A native `weighted` controller on the session's model with the compared task set."""
    from lab.controller.constraints import ContactLimits
    from lab.controller.controller import ControllerConfig
    from lab.controller.model import RobotModel
    from lab.controller.native import NativeController
    from lab.controller.stack import Stack
    from lab.controller.tasks import TaskGains
    from lab.description import load_description

    description = load_description(robot)
    model = RobotModel(session.model.model, session.model.contacts)
    stack = Stack.of([[*CONSTRAINTS[robot], *TASKS]])
    scale = WEIGHT_SCALE[robot]
    gains = {name: replace(g, weight=scale * g.weight) for name, g in description.gains.items()}
    gains |= {name: TaskGains(weight=scale) for name in TASKS if name not in gains}
    config = ControllerConfig(
        stack,
        gains,
        method="weighted",
        limits=ContactLimits(friction=description.friction),
        kernel="native",
    )
    refs = session.controller.references
    controller = NativeController(model, refs, config, session.controller.torque_limits())
    if controller.kernel_note:
        raise SystemExit(f"bench_tsid: the native kernel cannot run: {controller.kernel_note}")
    return controller


def problem_for_tsid(session: object, controller: object, states: list) -> dict:
    """What the TSID worker needs to build the same problem: the model (pinocchio's own
    serialization), contacts, gains, weights, limits, and the states with their references."""
    model = controller.robot
    gains = controller.gains()
    limits = controller.config.limits
    return {
        "model": model_spec(model.model),
        "check": {"q": states[0][0].tolist(), "v": states[0][1].tolist()}
        | _dynamics(model, states[0]),
        "contacts": [
            {"name": c.name, "frame": c.frame, "kind": c.kind}
            | (
                {"half_length": c.half_length, "half_width": c.half_width}
                if c.kind == "flat"
                else {}
            )
            for c in model.contacts
        ],
        "gains": {
            t: {"kp": gains[t].kp, "kd": gains[t].kd, "weight": gains[t].weight} for t in TASKS
        },
        "weight_scale": TSID_WEIGHT_SCALE,
        "friction": limits.friction,
        "normal_min": limits.normal_min,
        "normal_max": limits.normal_max,
        "base_frame": model.model.names[1],
        "states": [
            {
                "q": q.tolist(),
                "v": v.tolist(),
                "com": refs.com.tolist(),
                "com_velocity": refs.com_velocity.tolist(),
                "posture": refs.posture.tolist(),
                "base_rotation": refs.base_rotation.tolist(),
                "base_angular_velocity": refs.base_angular_velocity.tolist(),
            }
            for q, v, refs in states
        ],
    }


def model_spec(model: object) -> dict:
    """The pinocchio model as plain data: joints (type, axis, parent, placement, inertia) and
    frames, in index order. pinocchio's own serialization does not cross from 4.1 to 4.0 (`input
    stream error`), so the worker rebuilds the very same model from these with pinocchio's
    addJoint / appendBodyToJoint / addFrame, and checks M and h against ours."""
    joints = []
    for jid in range(1, model.njoints):
        joint, inertia = model.joints[jid], model.inertias[jid]
        axis = getattr(joint.extract(), "axis", None)
        joints.append(
            {
                "name": model.names[jid],
                "type": joint.shortname(),
                "axis": None if axis is None else np.asarray(axis).tolist(),
                "parent": int(model.parents[jid]),
                "placement": model.jointPlacements[jid].homogeneous.tolist(),
                "mass": inertia.mass,
                "lever": inertia.lever.tolist(),
                "inertia": inertia.inertia.tolist(),
            }
        )
    frames = [
        {
            "name": f.name,
            "joint": int(f.parentJoint),
            "frame": int(f.parentFrame),
            "placement": f.placement.homogeneous.tolist(),
            "type": str(f.type),
        }
        for f in list(model.frames)[1:]
    ]
    return {"joints": joints, "frames": frames, "armature": np.asarray(model.armature).tolist()}


def _dynamics(model: object, state: tuple) -> dict:
    """M and h at a state, for the worker's check that its model is ours."""
    model.update(state[0], state[1])
    return {"M": model.M.tolist(), "h": model.h.tolist()}


def our_answer(controller: object, q: np.ndarray, v: np.ndarray, refs: object) -> dict:
    """q̈, F (point feet: world force; soles: wrench in the sole frame) and τ of our kernel, and
    how many of its inequality rows bind."""
    controller.references = refs
    out = controller.compute(q, v)
    assert controller.kernel_ran == "native"
    problem = controller.build_problem()  # the Python rows of the same problem, to count binding
    C = np.vstack([level.C for level in problem.levels])
    d = np.concatenate([level.d for level in problem.levels])
    x = np.r_[out.qdd, out.forces]
    binding = int(np.sum(C @ x - d > -1e-7 * (1.0 + np.abs(d))))
    return {"qdd": out.qdd, "forces": out.forces, "tau": out.tau, "binding": binding}


def time_ours(controller: object, states: list, ticks: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-tick µs of `compute(q, v)` (the model update, rows, solve and τ in one crossing, as
    a session's tick calls it) cycling through the states (references swapped in per tick, as
    TSID's are set per tick), and the kernel's own update + solve time inside it."""
    us, inside = np.empty(ticks), np.empty(ticks)
    for i in range(ticks):
        q, v, refs = states[i % len(states)]
        start = time.perf_counter()
        controller.references = refs
        controller.compute(q, v)
        us[i] = (time.perf_counter() - start) * 1e6
        inside[i] = sum(controller.kernel_seconds) * 1e6
    return us, inside


# ------------------------------------------------------------------------------ the TSID worker
def model_from_spec(pin: object, spec: dict) -> object:
    """The model `model_spec` describes, built with the worker's pinocchio."""
    model = pin.Model()
    for j in spec["joints"]:
        kind = j["type"]
        if kind == "JointModelRevoluteUnaligned":
            joint = pin.JointModelRevoluteUnaligned(*np.ravel(j["axis"]))
        elif kind == "JointModelPrismaticUnaligned":
            joint = pin.JointModelPrismaticUnaligned(*np.ravel(j["axis"]))
        else:  # JointModelFreeFlyer, JointModelRX, JointModelPY, ...: no arguments
            joint = getattr(pin, kind)()
        jid = model.addJoint(j["parent"], joint, pin.SE3(np.array(j["placement"])), j["name"])
        inertia = pin.Inertia(j["mass"], np.array(j["lever"]), np.array(j["inertia"]))
        model.appendBodyToJoint(jid, inertia, pin.SE3.Identity())
    types = {str(t): t for t in pin.FrameType.values.values()}
    for f in spec["frames"]:
        frame = pin.Frame(
            f["name"], f["joint"], f["frame"], pin.SE3(np.array(f["placement"])), types[f["type"]]
        )
        model.addFrame(frame, False)
    model.armature = np.array(spec["armature"])
    return model


def _model_error(pin: object, model: object, check: dict) -> float:
    """The largest |M − M_lab|, |h − h_lab| at the check state (0 for the very same model)."""
    data = model.createData()
    q, v = np.array(check["q"]), np.array(check["v"])
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    h = pin.nonLinearEffects(model, data, q, v)
    return float(
        max(np.abs(M - np.array(check["M"])).max(), np.abs(h - np.array(check["h"])).max())
    )


class TsidProblem:
    """TSID's InverseDynamicsFormulationAccForce with the task set of the module docstring."""

    def __init__(self, spec: dict, solver: str) -> None:
        import pinocchio as pin
        import tsid

        self.pin, self.tsid = pin, tsid
        model = model_from_spec(pin, spec["model"])
        self.model_error = _model_error(pin, model, spec["check"])
        self.robot = tsid.RobotWrapper(model, tsid.FLOATING_BASE_SYSTEM, False)
        self.formulation = tsid.InverseDynamicsFormulationAccForce("tsid", self.robot, False)
        q0, v0 = np.array(spec["states"][0]["q"]), np.array(spec["states"][0]["v"])
        self.formulation.computeProblemData(0.0, q0, v0)
        data = self.formulation.data()
        gains, scale = spec["gains"], spec["weight_scale"]
        mu = spec["friction"] / math.sqrt(2.0)  # the lab's inner pyramid: (√2/2) μ on each tangent
        normal = np.array([0.0, 0.0, 1.0])
        self.contacts = []
        for c in spec["contacts"]:
            if c["kind"] == "point":
                contact = tsid.ContactPoint(
                    c["name"],
                    self.robot,
                    c["frame"],
                    normal,
                    mu,
                    spec["normal_min"],
                    spec["normal_max"],
                )
                contact.useLocalFrame(False)  # forces and rows in world axes, as the lab's
                reg = np.ones(3)
            else:
                L, W = c["half_length"], c["half_width"]
                corners = np.array([[L, L, -L, -L], [W, -W, W, -W], [0.0, 0.0, 0.0, 0.0]])
                contact = tsid.Contact6d(
                    c["name"],
                    self.robot,
                    c["frame"],
                    corners,
                    normal,
                    mu,
                    spec["normal_min"],
                    spec["normal_max"],
                )
                reg = np.ones(6)
            contact.setKp(np.zeros(contact.n_motion))
            contact.setKd(gains["contact"]["kd"] * np.ones(contact.n_motion))
            contact.setRegularizationTaskWeightVector(reg)
            frame = self.robot.model().getFrameId(c["frame"])
            contact.setReference(self.robot.framePosition(data, frame))
            self.formulation.addRigidContact(
                contact, scale * gains["forces"]["weight"], scale * gains["contact"]["weight"], 1
            )
            self.contacts.append((c, contact))
        nv, na = self.robot.nv, self.robot.na
        self.com = tsid.TaskComEquality("task-com", self.robot)
        self.com.setKp(gains["com"]["kp"] * np.ones(3))
        self.com.setKd(gains["com"]["kd"] * np.ones(3))
        self.formulation.addMotionTask(self.com, scale * gains["com"]["weight"], 1, 0.0)
        self.base = tsid.TaskSE3Equality("task-base", self.robot, spec["base_frame"])
        self.base.setKp(gains["base_orientation"]["kp"] * np.ones(6))
        self.base.setKd(gains["base_orientation"]["kd"] * np.ones(6))
        self.base.setMask(np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0]))
        self.base.useLocalFrame(False)
        self.formulation.addMotionTask(
            self.base, scale * gains["base_orientation"]["weight"], 1, 0.0
        )
        self.posture = tsid.TaskJointPosture("task-posture", self.robot)
        self.posture.setKp(gains["posture"]["kp"] * np.ones(na))
        self.posture.setKd(gains["posture"]["kd"] * np.ones(na))
        self.formulation.addMotionTask(self.posture, scale * gains["posture"]["weight"], 1, 0.0)
        self.solver = getattr(tsid, solver)("qp")
        self.solver.resize(self.formulation.nVar, self.formulation.nEq, self.formulation.nIn)
        self.nv, self.na = nv, na
        self.states = [self._state(s) for s in spec["states"]]

    def _state(self, s: dict) -> tuple:
        """(q, v, CoM sample, base sample, posture sample) of one recorded state."""
        tsid, pin = self.tsid, self.pin
        q, v = np.array(s["q"]), np.array(s["v"])
        com = tsid.TrajectorySample(3)
        com.value(np.array(s["com"]))
        com.derivative(np.array(s["com_velocity"]))
        com.second_derivative(np.zeros(3))
        base = tsid.TrajectorySample(12, 6)
        base.value(tsid.SE3ToVector(pin.SE3(np.array(s["base_rotation"]), np.zeros(3))))
        base.derivative(np.r_[np.zeros(3), s["base_angular_velocity"]])
        base.second_derivative(np.zeros(6))
        posture = tsid.TrajectorySample(self.na)
        posture.value(np.array(s["posture"]))
        posture.derivative(np.zeros(self.na))
        posture.second_derivative(np.zeros(self.na))
        return q, v, com, base, posture

    def tick(self, i: int) -> object:
        """One tick at state i: references, problem data, solve; returns the solution."""
        q, v, com, base, posture = self.states[i]
        self.com.setReference(com)
        self.base.setReference(base)
        self.posture.setReference(posture)
        hqp = self.formulation.computeProblemData(0.0, q, v)
        solution = self.solver.solve(hqp)
        self.formulation.getActuatorForces(solution)
        return solution

    def answer(self, i: int) -> dict:
        """q̈, F in the lab's layout (point: world force; sole: wrench G f in the sole frame), τ,
        and how many of TSID's friction rows bind."""
        solution = self.tick(i)
        if solution.status != 0:
            return {"error": f"TSID's QP failed at state {i} (status {solution.status})"}
        forces, binding = [], 0
        for _, contact in self.contacts:
            f = self.formulation.getContactForce(contact.name, solution)
            forces.append(contact.getForceGeneratorMatrix @ f if len(f) == 12 else f)
            q, v = self.states[i][0], self.states[i][1]
            rows = contact.computeForceTask(0.0, q, v, self.formulation.data())
            value = rows.matrix @ f
            binding += int(
                np.sum(value - rows.lowerBound < 1e-7) + np.sum(rows.upperBound - value < 1e-7)
            )
        return {
            "qdd": self.formulation.getAccelerations(solution).tolist(),
            "forces": np.concatenate(forces).tolist(),
            "tau": self.formulation.getActuatorForces(solution).tolist(),
            "binding": binding,
        }

    def time(self, ticks: int) -> list[float]:
        """Per-tick µs of `tick`, cycling through the states."""
        us = []
        n = len(self.states)
        for i in range(ticks):
            start = time.perf_counter()
            self.tick(i % n)
            us.append((time.perf_counter() - start) * 1e6)
        return us


def worker() -> int:
    """JSON lines on stdin → JSON lines on stdout: setup, answer, time, quit."""
    problems: dict[str, TsidProblem] = {}
    for line in sys.stdin:
        request = json.loads(line)
        verb = request["verb"]
        if verb == "quit":
            return 0
        if verb == "setup":
            spec = json.loads(Path(request["spec"]).read_text())
            problem = problems[request["robot"]] = TsidProblem(spec, request["solver"])
            reply: object = {"model_error": problem.model_error}
        elif verb == "answer":
            reply = problems[request["robot"]].answer(request["state"])
        else:  # time
            reply = problems[request["robot"]].time(request["ticks"])
        print(json.dumps(reply), flush=True)
    return 0


class Worker:
    """The TSID worker process, asked one request at a time."""

    def __init__(self, python: Path) -> None:
        self.process = subprocess.Popen(
            [str(python), "-W", "ignore", str(Path(__file__).resolve()), "--worker"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )

    def ask(self, **request: object) -> object:
        """Send one request, return the worker's reply."""
        self.process.stdin.write(json.dumps(request) + "\n")
        self.process.stdin.flush()
        line = self.process.stdout.readline()
        if not line:
            raise SystemExit("bench_tsid: the TSID worker stopped (its error is above)")
        return json.loads(line)

    def close(self) -> None:
        """Ask the worker to quit and wait for it."""
        self.process.stdin.write(json.dumps({"verb": "quit"}) + "\n")
        self.process.stdin.close()
        self.process.wait(timeout=30)


# ------------------------------------------------------------------------------ the report
def compare(ours: dict, theirs: dict) -> dict[str, float]:
    """The largest |ours − TSID| / (1 + |TSID|) of q̈, F and τ."""
    return {
        key: float(
            np.max(np.abs(np.asarray(ours[key]) - theirs[key]) / (1.0 + np.abs(theirs[key])))
        )
        for key in ("qdd", "forces", "tau")
    }


def stats(us: np.ndarray) -> str:
    """Median, p99 and minimum (µs), formatted."""
    return f"{np.median(us):7.1f} {np.percentile(us, 99):7.1f} {np.min(us):7.1f}"


def bench_robot(worker_: Worker, robot: str, args: argparse.Namespace, tmp: Path) -> dict:
    """Record the states, check the answers, time both sides in alternating blocks."""
    recorded = record_states(robot, args.standing, args.pushed)
    session, states = recorded["session"], recorded["states"]
    controller = our_controller(session, robot)
    spec = tmp / f"{robot}.json"
    spec.write_text(json.dumps(problem_for_tsid(session, controller, states)))
    setup = worker_.ask(verb="setup", robot=robot, spec=str(spec), solver=args.solver)
    if setup["model_error"] > 1e-9:
        raise SystemExit(
            f"bench_tsid: {robot}: TSID's model is not ours (M, h differ by "
            f"{setup['model_error']:.1e})"
        )
    worst = {"qdd": 0.0, "forces": 0.0, "tau": 0.0}
    binding = []
    for i, (q, v, refs) in enumerate(states):
        ours = our_answer(controller, q, v, refs)
        theirs = worker_.ask(verb="answer", robot=robot, state=i)
        if "error" in theirs:
            raise SystemExit(f"bench_tsid: {robot}: {theirs['error']}")
        for key, error in compare(ours, theirs).items():
            worst[key] = max(worst[key], error)
        binding.append((ours["binding"], theirs["binding"]))
    ours_us, inside_us, tsid_us = [], [], []
    for _ in range(args.blocks):  # alternate, so the load falls on both alike
        tsid_us.append(np.array(worker_.ask(verb="time", robot=robot, ticks=args.ticks)))
        us, inside = time_ours(controller, states, args.ticks)
        ours_us.append(us)
        inside_us.append(inside)
    return {
        "robot": robot,
        "states": len(states),
        "worst": worst,
        "binding": binding,
        "ours": np.concatenate(ours_us),
        "inside": np.concatenate(inside_us),
        "tsid": np.concatenate(tsid_us),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--venv", type=Path, default=DEFAULT_VENV, help="the TSID venv")
    parser.add_argument("--from-source", action="store_true", help="build libtsid from its sdist")
    parser.add_argument("--robots", nargs="+", default=list(ROBOTS), choices=ROBOTS)
    parser.add_argument(
        "--solver",
        default="SolverHQuadProgFast",
        choices=("SolverHQuadProgFast", "SolverHQuadProg"),
    )
    parser.add_argument("--standing", type=int, default=4, help="standing states")
    parser.add_argument("--pushed", type=int, default=4, help="states during and after the push")
    parser.add_argument("--blocks", type=int, default=10, help="alternating timing blocks")
    parser.add_argument("--ticks", type=int, default=300, help="ticks per block and side")
    args = parser.parse_args(argv)
    if args.worker:
        return worker()
    from lab.controller.native import NOT_BUILT

    if NOT_BUILT:
        raise SystemExit(f"bench_tsid: {NOT_BUILT}")
    python = ensure_tsid_venv(args.venv, args.from_source)
    worker_ = Worker(python)
    rows = []
    try:
        with tempfile.TemporaryDirectory() as tmp:
            rows = [bench_robot(worker_, robot, args, Path(tmp)) for robot in args.robots]
    finally:
        worker_.close()
    print(
        f"TSID 1.10.0 ({args.solver}) against the native kernel (weighted), "
        f"{args.blocks} alternating blocks of {args.ticks} ticks per side"
    )
    print(f"{'robot':7} {'side':18} {'p50 µs':>7} {'p99 µs':>7} {'min µs':>7}")
    failed = False
    for row in rows:
        print(f"{row['robot']:7} {'TSID':18} {stats(row['tsid'])}")
        print(f"{row['robot']:7} {'ours (compute)':18} {stats(row['ours'])}")
        print(f"{row['robot']:7} {'ours, inside kernel':18} {stats(row['inside'])}")
        ratio = np.median(row["ours"]) / np.median(row["tsid"])
        worst = row["worst"]
        agree = max(worst.values()) <= AGREEMENT
        failed |= not agree
        print(
            f"{row['robot']:7} ours/TSID median {ratio:.2f}   agreement over {row['states']} "
            f"states: q̈ {worst['qdd']:.1e}  F {worst['forces']:.1e}  τ {worst['tau']:.1e} "
            f"({'within' if agree else 'OUTSIDE'} {AGREEMENT:.0e}·(1+|x|))   binding rows "
            f"ours/TSID per state: {row['binding']}"
        )
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
