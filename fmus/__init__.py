"""FMU sources: the plant in C99 behind the FMI 2.0 API, and its variable table.

``hybridsim fmu build`` (``hybridsim.fmu.build_plant_fmu``) generates
``modelDescription.xml`` and ``plant_vars.h`` from :mod:`fmus.plant_model`,
compiles ``plant.c`` with the system C compiler against the vendored FMI 2.0
headers in ``include/`` (2-clause BSD, Modelica Association) and zips the FMU.
"""
