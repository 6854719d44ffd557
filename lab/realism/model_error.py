"""Model error: the controller's pinocchio model with perturbed link masses and CoMs.

The simulator keeps the URDF's inertias; the controller gets a copy whose every body's mass is
scaled by (1 + e·u), u uniform in [−1, 1], and whose CoM moves by c·u' (u' uniform in [−1, 1]³,
m), drawn from the seed (lab/realism/rng.py, its own stream). The rotational inertia about the
CoM scales with the mass. Built once with the session's parts (no per-tick part, so no C++ twin:
the native kernel is built from this very model, lab/controller/native.py `kernel_for`).
"""

import pinocchio as pin

from lab.realism.rng import uniforms

MODEL_ERROR_STREAM = 0x6D6F64656C  # "model": the model error's draws, apart from the noise's


def perturbed_model(model: pin.Model, mass_error: float, com_error: float, seed: int) -> pin.Model:
    """A copy of `model` with its bodies' masses and CoMs perturbed (the module docstring);
    `model` itself is left as it is."""
    copy = model.copy()
    if mass_error == 0.0 and com_error == 0.0:
        return copy
    draws = 2.0 * uniforms(seed ^ MODEL_ERROR_STREAM, 0, 4 * model.njoints) - 1.0
    for joint in range(1, model.njoints):
        inertia = copy.inertias[joint]
        if inertia.mass <= 0.0:
            continue
        u = draws[4 * joint : 4 * joint + 4]
        scale = 1.0 + mass_error * u[0]
        copy.inertias[joint] = pin.Inertia(
            inertia.mass * scale, inertia.lever + com_error * u[1:4], inertia.inertia * scale
        )
    return copy


def mass_of(model: pin.Model) -> float:
    """Total mass of `model` (kg)."""
    return float(sum(model.inertias[j].mass for j in range(1, model.njoints)))


def relative_mass_change(true: pin.Model, perturbed: pin.Model) -> float:
    """(m_perturbed − m_true) / m_true: how far the controller's weight estimate is off."""
    return mass_of(perturbed) / mass_of(true) - 1.0
