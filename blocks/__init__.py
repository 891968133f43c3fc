"""The hybridsim block library: the blocks of the paper's Fig 6 and friends.

Importing this package registers every block type with
:mod:`hybridsim.registry`; diagrams refer to them by these names.
"""
from . import basic, bouncing, controllers, kinematics, manipulator, sources, surface, wrist  # noqa: F401
