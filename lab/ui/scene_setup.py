"""Picking a scene made for a set-up (`lab.scenes.setups`) asks first: a dialog lists the
commands (stack preset, hierarchy method, momentum law, internal force), and the scene is
switched on the answer, *Use it* with the set-up (the `scene` command's `setup`: the lab installs
it before the scene's first tick), *Keep mine* without. Nothing is changed unasked: a lab lets
the user try the scene with any stack, but says what it was made for. Asking after the switch
let Bolt fall on the split wedges (at 0.3-0.5 s) before anyone could answer.
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


def switch_scene(
    app: CommandHost, client: viser.ClientHandle, scene: str, robot: str | None, mass_kg: float
) -> None:
    """Switch to `scene`; if it was made for a set-up for `robot` (of `mass_kg`), ask in
    `client`'s browser first and switch on the answer."""
    setup = SCENE_SETUPS.get(scene)
    if setup is None or robot not in setup.robots:
        app.send(client, "scene", {"name": scene})
        return
    gui = client.gui
    with gui.add_modal(f"Scene {scene} was made for this set-up") as modal:
        gui.add_markdown(
            f"{setup.why}:\n\n"
            + "\n".join(f"- {line}" for line in setup_lines(setup.commands(mass_kg)))
        )
        use = gui.add_button("Use it")
        keep = gui.add_button("Keep mine")

    def answer(with_setup: bool) -> None:
        modal.close()
        app.send(client, "scene", {"name": scene, "setup": with_setup})

    use.on_click(app.guard(lambda _: answer(True)))
    keep.on_click(app.guard(lambda _: answer(False)))
