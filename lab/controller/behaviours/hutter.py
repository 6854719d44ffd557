"""The behaviours of the Hutter 2014 §5.1 experiments, by gait name."""

from lab.controller.behaviours.body_motion import ForwardShift, HeightStep
from lab.controller.behaviours.static_walk import StaticWalk, StaticWalkHalfCylinder

HUTTER_BEHAVIOURS = {
    behaviour.name: behaviour
    for behaviour in (StaticWalk, StaticWalkHalfCylinder, HeightStep, ForwardShift)
}
