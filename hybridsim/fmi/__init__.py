"""FMI tools beyond the FMU block (:mod:`hybridsim.fmu`): export a diagram as an FMU.

* :func:`~hybridsim.fmi.export.export_fmu` (``hybridsim fmu export``) wraps a
  diagram or subsystem file as a Co-Simulation FMU (FMI 2.0 or 3.0).
* :mod:`hybridsim.fmi.runtime` advances a diagram one communication step at a time.
"""
