"""Picking a scene offers the set-up it was made for (`lab.scenes.setups`): a dialog lists the
commands (stack preset, hierarchy method, momentum law, internal force) and sends them on *Use
it*; *Keep mine* leaves the controller as it is. Nothing is changed unasked: a lab lets the user
try the scene with any stack, but says what it was made for.
"""

from __future__ import annotations

import viser

from lab.scenes.setups import SCENE_SETUPS
from lab.ui.balance_controls import CommandHost


def setup_lines(commands: list[tuple[str, dict]]) -> list[str]:
    """One line per command, as the protocol reads it."""
    return [
        f"`{verb}` " + ", ".join(f"{k} {v}" for k, v in payload.items())
        for verb, payload in commands
    ]


def offer_scene_setup(
    app: CommandHost, client: viser.ClientHandle, scene: str, robot: str, mass_kg: float
) -> bool:
    """Open the dialog for `scene` in `client`'s browser if the scene has a set-up for `robot`
    (of `mass_kg`); whether it did."""
    setup = SCENE_SETUPS.get(scene)
    if setup is None or robot not in setup.robots:
        return False
    commands = setup.commands(mass_kg)
    gui = client.gui
    with gui.add_modal(f"Scene {scene} was made for this set-up") as modal:
        gui.add_markdown(
            f"{setup.why}:\n\n" + "\n".join(f"- {line}" for line in setup_lines(commands))
        )
        use = gui.add_button("Use it")
        keep = gui.add_button("Keep mine")

    def use_it(_: viser.GuiEvent) -> None:
        modal.close()
        for verb, payload in commands:
            reply = app.send(client, verb, payload)
            if reply is None or not reply.get("ok"):
                return  # the refusal is shown and logged by `send`

    use.on_click(app.guard(use_it))
    keep.on_click(app.guard(lambda _: modal.close()))
    return True
