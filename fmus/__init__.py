"""The plant FMU: the arm, wrist and surface of the paper in C99 behind FMI 2.0 and 3.0.

``hybridsim fmu build`` (:func:`hybridsim.fmus.build.build_plant_fmu`) generates
``modelDescription.xml`` and ``plant_vars.h`` from :mod:`.plant_model`, compiles
the model (``plant_core.h``) behind ``plant.c`` (FMI 2.0) or ``plant3.c`` (FMI 3.0)
with the system C compiler against the FMI headers fmpy ships, and zips the FMU.
"""
