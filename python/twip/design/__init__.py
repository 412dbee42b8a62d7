"""Designing a controller for a robot: tunable knobs per controller family
(`twip.design.knobs`), `tune` (knobs tuned over uncertain robots), `worst_case` (the worst
robot in a perturbation's support), and controller files (`--controller tuned.toml`)."""
from twip.design.knobs import FAMILIES, Knob, family_of  # noqa: F401
from twip.design.tune import Tuning, TuningError, tune  # noqa: F401
from twip.design.worst_case import WorstCase, worst_case  # noqa: F401
