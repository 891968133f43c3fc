"""Force control over the generic core: its signal roles, metrics, figures and hand modes.

A diagram of a force-controlled manipulator names its signals by role
(``signals: {force: ..., force_desired: ..., position: ..., contact: ...}``); with
them ``hybridsim run`` computes force-control metrics (rise time, overshoot,
steady-state force error, position error, contact lost and when), prints them,
and draws position above force (desired dashed, force after a 12 Hz display
filter), and ``hybridsim analyze`` reports the plant mode nearest
``analysis: hand_mode_hz``.

None of this is in the generic layers: importing this package registers it
there, the way the block library registers its blocks -

* :mod:`.settings`: the roles (``signals``) and the keys of ``metrics``, ``plot``
  and ``analysis`` (:func:`hybridsim.format.tables.extend`);
* :mod:`.metrics`: the metric set and its summary phrases
  (:func:`hybridsim.analysis.metrics.register`);
* :mod:`.figures`: the figure layout (:func:`hybridsim.report.figures.register_layout`);
* :mod:`.modes`: the hand mode of the linearized plant
  (:func:`hybridsim.analysis.extras.register`).

``import hybridsim`` imports it.
"""
from hybridsim.forcecontrol import settings  # noqa: F401  (first: the others read its tables)
from hybridsim.forcecontrol import figures, metrics, modes  # noqa: F401
