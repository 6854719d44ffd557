"""Warnings that teach (pure: tested in tests/ui/test_ui_logic.py): what a stack edit will do to the
robot before it is applied, and what a hierarchy switch that dropped the robot changed."""

from collections.abc import Sequence

CONTACT_TASK = "contact"


def stack_risks(levels: Sequence[Sequence[str]]) -> list[str]:
    """Why the stack `levels` will drop the robot ([] when nothing is obviously wrong). A lab
    allows it; the panel asks before applying."""
    if not any(levels):
        return ["every task is off: nothing holds the robot up, it will fall"]
    if not any(CONTACT_TASK in level for level in levels):
        return [
            f"the robot will fall: no {CONTACT_TASK} task (nothing keeps the feet on the ground "
            "and the contact forces consistent)"
        ]
    return []


def standing_risks(levels: Sequence[Sequence[str]], tasks: Sequence[str], gait: str) -> list[str]:
    """Why the acknowledged stack `levels` is unlikely to hold the robot under `gait` ([] when
    nothing is obviously wrong); `tasks` names the tasks (the other names are constraints,
    which belong above the contacts)."""
    risks = stack_risks(levels)
    if risks:
        return risks
    contact = next(k for k, level in enumerate(levels) if CONTACT_TASK in level)
    above = [name for level in levels[:contact] for name in level if name in tasks]
    if above:
        risks.append(
            f"{', '.join(above)} above the {CONTACT_TASK} task: the feet may slip or lift to "
            "serve it (the contacts belong at the top, under the physical limits only)"
        )
    if gait == "stand" and any("swing_feet" in level for level in levels):
        risks.append(
            "a stepping stack (swing_feet) with the stand gait: made for walking, it may not "
            "stand (Bolt fell under kim_stepping); choose the gait or *Default stack*"
        )
    return risks


def error_growth(before: dict, after: dict, top: int = 3) -> str:
    """Which tasks lost most between two telemetry messages (before a hierarchy switch and at a
    fall after it): the `top` largest growths of task error, with their level."""
    old = {t["name"]: t["error"] for t in before["tasks"]}
    grew = sorted(
        ((t["error"] - old.get(t["name"], 0.0), t) for t in after["tasks"]),
        key=lambda item: -item[0],
    )
    parts = [
        f"level {t['level']} {t['name']} {old.get(t['name'], 0.0):.2g} → {t['error']:.2g}"
        for growth, t in grew[:top]
        if growth > 0.0
    ]
    return "; ".join(parts) if parts else "no task error grew"
