"""Build the plant FMU: the model of :mod:`.plant_model` behind FMI 2.0 or 3.0."""
from pathlib import Path

from hybridsim.errors import InputError
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
    if isinstance(fmi, bool) or fmi not in (2, 3):  # a bad argument: the caller's input, not an FMU's failure
        raise InputError(f"FMI version {fmi!r}: the plant FMU is built as FMI 2 or 3")
    here = Path(__file__).parent
    headers = {"plant_vars.h": pm.vars_header(), "plant_core.h": (here / "plant_core.h").read_text()}
    extra = {"sources/buildDescription.xml": pm.build_description()} if fmi == 3 else {}
    return build_fmu(out, pm.MODEL_NAME, [here / f for f in pm.C_FILES[fmi]], pm.model_description(fmi),
                     headers, extra_files=extra)


def write_plant_fmu(output=None, fmi=2):
    """Build the plant FMU into a file of the user's (``hybridsim fmu build``).

    Parameters
    ----------
    output : path-like, optional
        The ``.fmu`` to write. Default ``plant.fmu`` in the working folder, where a
        ``plant.fmu`` hybridsim did not write is kept and the next free name
        ``plant-2.fmu``, ... is used.
    fmi : {2, 3}
        The FMI version.

    Returns
    -------
    (pathlib.Path, str or None)
        The FMU written, and a note saying why it is not the default name (or None).
    """
    from hybridsim.files import check_output_file, default_output_file, note_written

    if output:
        out, note = check_output_file(output, ["fmu"]), None
    else:  # the default name: a file hybridsim did not write is kept, the next free name taken
        out, note = default_output_file("plant.fmu")
        check_output_file(out, ["fmu"])
    out = build_plant_fmu(out, fmi=fmi)
    note_written(out)
    return Path(out), note
