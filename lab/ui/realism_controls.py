"""The panel's "Realism" folder (issue 30, docs/realism.md): a preset (ideal, typical, harsh)
and one slider per knob of lab/realism/knobs.py with its range and unit, the actuator model,
the state estimator (true state or EKF) and a payload on the base. *Apply* sends one `realism`
command with the knobs moved away from what the server acknowledged in `info` (a change of
mass_error, com_error or seed rebuilds the controller's model: the robot stands again); the
sliders show the acknowledged knobs.
"""

from __future__ import annotations

import viser

from lab.protocol.realism import ACTUATORS, ESTIMATORS, KNOBS, PAYLOAD_MASS_MAX, PRESET_NAMES
from lab.ui.balance_controls import CommandHost

# A continuous knob's slider step, a fraction of its range: fine enough to show a datasheet's
# 1.745e-4 rad/s/√Hz on a 0–0.1 range (a coarse step would snap it to 0).
SLIDER_RESOLUTION = 1e-6


class RealismControls:
    """Preset and knob sliders and *Apply*; payload mass and *Set payload* (on the base)."""

    def __init__(self, app: CommandHost, gui: viser.GuiApi, order: float) -> None:
        self.app = app
        with gui.add_folder(
            "Realism (sensors, actuators, model)", order=order, expand_by_default=False
        ):
            self.preset = gui.add_dropdown("Realism preset", PRESET_NAMES, initial_value="ideal")
            load = gui.add_button("Run preset")
            self.actuator = gui.add_dropdown("Actuator", ACTUATORS, initial_value="ideal")
            self.estimator = gui.add_dropdown("Estimator", ESTIMATORS, initial_value="true")
            self.knobs = {
                name: gui.add_slider(
                    f"{name} [{knob.unit}]" if knob.unit else name,
                    knob.lo,
                    knob.hi,
                    1 if knob.integer else (knob.hi - knob.lo) * SLIDER_RESOLUTION,
                    knob.lo,
                    hint=knob.meaning,
                )
                for name, knob in KNOBS.items()
                if name != "seed"
            }
            self.seed = gui.add_number("seed", 0, min=0, step=1, hint=KNOBS["seed"].meaning)
            apply = gui.add_button("Apply knobs")
            self.payload = gui.add_slider("Payload on base [kg]", 0.0, PAYLOAD_MASS_MAX, 0.5, 0.0)
            set_payload = gui.add_button("Set payload")
            self.note = gui.add_markdown("")
        self.base_body = "base"
        self._shown: dict[str, float | int | str] = {}  # the knobs the server acknowledged
        self.controls: list = [self.preset, load, self.actuator, self.estimator]
        self.controls += list(self.knobs.values())
        self.controls += [self.seed, apply, self.payload, set_payload]
        load.on_click(app.guard(self._load))
        apply.on_click(app.guard(self._apply))
        set_payload.on_click(app.guard(self._set_payload))

    def show_info(self, info: dict) -> None:
        """The knobs the server runs (`info["realism"]`), without sending them back."""
        self.base_body = info.get("base", self.base_body)
        knobs = info.get("realism")
        if knobs is None:
            return
        self._shown = dict(knobs)
        for name, slider in self.knobs.items():
            slider.value = knobs[name]
        self.seed.value = knobs["seed"]
        self.actuator.value = knobs["actuator"]
        self.estimator.value = knobs["estimator"]
        if knobs["preset"] in PRESET_NAMES:
            self.preset.value = knobs["preset"]
        self.payload.value = info.get("payloads", {}).get(self.base_body, 0.0)

    def _reply(self, what: str, reply: dict | None) -> None:
        ok = reply is not None and reply.get("ok")
        self.note.content = f"✔ {what}" if ok else f"⚠ {what} refused: see the event log"

    def _load(self, event: viser.GuiEvent) -> None:
        if event.client is not None:
            reply = self.app.send(event.client, "realism", {"preset": self.preset.value})
            self._reply(f"preset {self.preset.value}", reply)

    def _apply(self, event: viser.GuiEvent) -> None:
        if event.client is None:
            return
        shown: dict[str, float | int | str] = {
            name: slider.value for name, slider in self.knobs.items()
        }
        shown |= {
            "seed": int(self.seed.value),
            "actuator": self.actuator.value,
            "estimator": self.estimator.value,
        }
        payload = {}
        for name, value in shown.items():
            knob = KNOBS.get(name)
            tolerance = 0.0 if knob is None else (knob.hi - knob.lo) * SLIDER_RESOLUTION / 2
            if name not in self._shown or _moved(value, self._shown[name], tolerance):
                payload[name] = value
        if not payload:
            self.note.content = "nothing moved: the knobs shown are the ones running"
            return
        self._reply(f"{', '.join(payload)}", self.app.send(event.client, "realism", payload))

    def _set_payload(self, event: viser.GuiEvent) -> None:
        if event.client is None:
            return
        payload = {"body": self.base_body, "mass": float(self.payload.value), "offset": [0, 0, 0.1]}
        self._reply(
            f"{self.payload.value:g} kg payload", self.app.send(event.client, "payload", payload)
        )


def _moved(value: float | int | str, acknowledged: float | int | str, tolerance: float) -> bool:
    """Whether a knob shown as `value` differs from the `acknowledged` one by more than the
    slider's rounding (`tolerance`)."""
    if isinstance(value, str) or isinstance(acknowledged, str):
        return value != acknowledged
    return abs(value - acknowledged) > tolerance
