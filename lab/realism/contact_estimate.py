"""Contact forces estimated from joint torques (Raiola 2020 eq. 18), for haptic touchdown in
place of the simulator's contact forces.

Per point foot, the leg's rows of the dynamics with its acceleration neglected:
F_c = −J_c⁻ᵀ (τ_c − h_c), J_c the 3 × 3 block of the foot's contact Jacobian on its leg's
joints (world axes), τ_c the torques the leg's drives apply (a torque sensor's reading), h_c
the leg's bias forces, both from the controller's model at the measured state. A flat foot (6
rows, a sole) or a leg of other than three joints has no square block: its estimate is NaN and
the session keeps the simulator's touch flag for it (docs/realism.md).
"""

import numpy as np

from lab.controller.model import BASE_DOF, RobotModel


def estimated_contact_forces(model: RobotModel, applied_torques: np.ndarray) -> np.ndarray:
    """The force (n_contacts, 3), N, world axes, the terrain exerts on each foot, estimated
    from `applied_torques` (N m, pinocchio joint order) by eq. 18; NaN where not estimable."""
    out = np.full((len(model.contacts), 3), np.nan)
    for i, (contact, rows) in enumerate(zip(model.contacts, model.force_slices, strict=True)):
        if contact.kind != "point":
            continue
        leg = model.Jc[rows, BASE_DOF:]
        joints = np.flatnonzero(np.any(leg != 0.0, axis=0))
        if joints.size != 3:
            continue
        # Raiola eq. 18: F = −J⁻ᵀ (τ − h) on the leg's rows of M q̈ + h = Sᵀτ + Jᵀ F
        out[i] = np.linalg.solve(
            leg[:, joints].T, model.h[BASE_DOF + joints] - applied_torques[joints]
        )
    return out
