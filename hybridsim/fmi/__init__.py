"""FMI tools: the pieces of the FMU block (:mod:`hybridsim.fmi.fmu_block`) and diagram export.

* :mod:`~hybridsim.fmi.variables`: FMU variables as ports, element names, types, checks.
* :mod:`~hybridsim.fmi.model_exchange`: the Model Exchange event protocol of the FMU block.
* :mod:`~hybridsim.fmi.build`: compile C sources into an FMU (``hybridsim fmu build``).
* :func:`~hybridsim.fmi.export.export_fmu` (``hybridsim fmu export``) wraps a
  diagram or subsystem file as a Co-Simulation FMU (FMI 2.0 or 3.0);
  :mod:`~hybridsim.fmi.runtime` advances a diagram one communication step at a time.
"""
