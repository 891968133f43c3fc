"""The hybridsim block library: the blocks of the paper's Fig 6 and friends.

Importing this package registers every block type with
:mod:`hybridsim.registry`; diagrams refer to them by these names.
"""
from . import (basic, bouncing, continuous, controllers, discrete, kinematics, manipulator, noise,  # noqa: F401
               nonlinear, sources, surface, wrist)
