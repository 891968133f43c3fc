"""Build the plant FMU: the model of :mod:`.plant_model` behind FMI 2.0 or 3.0."""
from pathlib import Path

from hybridsim.errors import FMUError
from hybridsim.fmi.fmu_block import build_fmu

from . import plant_model as pm


def build_plant_fmu(out="plant.fmu", fmi=2):
    """Build the hybridsim plant FMU (Co-Simulation + Model Exchange in one binary).

    Parameters
    ----------
    out : path-like
        The ``.fmu`` file to write.
    fmi : {2, 3}
        The FMI version: 2.0 or 3.0 (the same model and variables).

    Returns
    -------
    pathlib.Path
        ``out``.
    """
    if fmi not in (2, 3):
        raise FMUError(f"FMI version {fmi!r}: the plant FMU is built as FMI 2 or 3")
    here = Path(__file__).parent
    headers = {"plant_vars.h": pm.vars_header(), "plant_core.h": (here / "plant_core.h").read_text()}
    extra = {"sources/buildDescription.xml": pm.build_description()} if fmi == 3 else {}
    return build_fmu(out, pm.MODEL_NAME, [here / f for f in pm.C_FILES[fmi]], pm.model_description(fmi),
                     headers, extra_files=extra)
