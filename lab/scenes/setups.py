"""What each scene was made for: the stack, hierarchy method, momentum law and internal force
that the paper stood its robot with there (plain data: a `scene` command with `setup` installs
one before the scene's first tick, and the page asks whether to when the scene is picked,
docs/ui.md). On Herzog's block, platform and balance boards Talos fell at 2-3 s under the
Table 4 preset with no push, and stood with Table 2 and LQR; Bolt stands on Kim's split wedges
under WBOSC with the internal force pushing its feet apart, and falls without it.
"""

from dataclasses import dataclass

GRAVITY = 9.81


@dataclass(frozen=True)
class SceneSetup:
    """A scene's controller set-up; None leaves that part as it is."""

    why: str  # the paper and figure it comes from
    robots: tuple[str, ...]  # the robots it was made for
    preset: str | None = None  # a stack preset (stacks/<name>.toml)
    method: str | None = None  # hierarchy method
    momentum: str | None = None  # momentum law (the `momentum` command's mode)
    internal_force_weight_share: float | None = None  # reference as a share of m g, N/N
    internal_force_kp: float | None = None  # feedback gain K_F (Kim eq. 12)

    def commands(self, mass_kg: float) -> list[tuple[str, dict]]:
        """The protocol commands that install it on a robot of `mass_kg`, in order."""
        out: list[tuple[str, dict]] = []
        if self.preset is not None:
            out.append(("stack", {"preset": self.preset}))
        if self.method is not None:
            out.append(("hierarchy", {"method": self.method}))
        if self.momentum is not None:
            out.append(("momentum", {"mode": self.momentum}))
        if self.internal_force_kp is not None:
            out.append(("gains", {"task": "internal_force", "kp": self.internal_force_kp}))
        if self.internal_force_weight_share is not None:
            reference = round(self.internal_force_weight_share * mass_kg * GRAVITY, 2)
            out.append(("internal_force", {"reference": reference}))
        return out


_HERZOG = SceneSetup(
    "Herzog 2016 §5.2.3 (scenarios/herzog_block.toml, herzog_platform.toml, ...)",
    ("talos",),
    preset="herzog_table2",
    momentum="lqr_talos",
)
SCENE_SETUPS: dict[str, SceneSetup] = {
    "block": _HERZOG,
    "platform": _HERZOG,
    "balance_board": _HERZOG,
    "balance_board_lateral": _HERZOG,
    "split_wedges": SceneSetup(
        "Kim 2016 Fig. 6 (scenarios/kim_wedges_100n.toml: Hume's 100 N scaled to 0.51 m g)",
        ("bolt",),
        method="wbosc",
        internal_force_weight_share=0.51,
        internal_force_kp=1.0,
    ),
}
