"""Pure damper and vehicle physics: no I/O beyond reading a spec file."""

from shockdyno.model.composite import DamperModel, Evaluation, ModelInputs, Term
from shockdyno.model.damper import (
    ForceBreakdown,
    damper_force,
    evaluate,
    force_from_displacement,
    talbott_force,
)
from shockdyno.model.kinematics import differentiate
from shockdyno.model.params import Estimate, Param
from shockdyno.model.spec import DamperSpec, default_spec_path, load_spec

__all__ = [
    "DamperModel",
    "DamperSpec",
    "Estimate",
    "Evaluation",
    "ForceBreakdown",
    "ModelInputs",
    "Param",
    "Term",
    "damper_force",
    "default_spec_path",
    "differentiate",
    "evaluate",
    "force_from_displacement",
    "load_spec",
    "talbott_force",
]
