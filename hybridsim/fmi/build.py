"""Compile C sources behind the FMI 2.0 or 3.0 API into an FMU (``hybridsim fmu build``)."""
import os
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

from ..errors import FMUError
from ..files import atomic_file


def find_compiler():
    """Path of the system C compiler (cc or gcc), or raise FMUError."""
    for name in (os.environ.get("CC"), "cc", "gcc"):
        if name and shutil.which(name):
            return shutil.which(name)
    raise FMUError("no C compiler found (looked for $CC, cc, gcc): install gcc "
                   "(Debian/Ubuntu: sudo apt-get install gcc)")


def fmi_headers():
    """The folder of the FMI 2.0 and 3.0 C headers that fmpy ships (``fmpy/c-code``).

    Returns
    -------
    pathlib.Path
        The folder with ``fmi2Functions.h``, ``fmi3Functions.h`` and their includes.
    """
    import fmpy

    return Path(fmpy.__file__).parent / "c-code"


def build_fmu(out, model_identifier, sources, model_description, headers, include_dirs=None,
              extra_files=None):
    """Compile ``sources`` into a shared library and pack an FMU at ``out``.

    The binary goes where the model description's FMI version expects it
    (``binaries/linux64`` for 2.0, ``binaries/x86_64-linux`` for 3.0, and the
    matching folder and library suffix on macOS and Windows).

    Parameters
    ----------
    out : path-like
        The ``.fmu`` file to write (atomically).
    model_identifier : str
        The library's name, as in the model description.
    sources : list of path-like
        C files, compiled and packed into ``sources/``.
    model_description : str
        The text of ``modelDescription.xml``.
    headers : dict
        {file name: text} of generated headers, packed into ``sources/``.
    include_dirs : list of path-like, optional
        Folders whose ``*.h`` are packed and compiled against; default: the
        FMI headers of :func:`fmi_headers`.
    extra_files : dict, optional
        {path in the archive: text}, e.g. ``sources/buildDescription.xml``.

    Returns
    -------
    pathlib.Path
        ``out``.
    """
    import fmpy

    cc = find_compiler()
    out = Path(out)
    include_dirs = [fmi_headers()] if include_dirs is None else include_dirs
    with tempfile.TemporaryDirectory(prefix="hybridsim-fmu-") as tmp:
        tmp = Path(tmp)
        src = tmp / "sources"
        fmi3 = 'fmiVersion="3.0"' in model_description
        binary = tmp / "binaries" / (fmpy.platform_tuple if fmi3 else fmpy.platform)
        src.mkdir(parents=True)
        binary.mkdir(parents=True)
        for d in include_dirs:
            for h in Path(d).glob("*.h"):
                shutil.copy(h, src / h.name)
        for name, text in headers.items():
            (src / name).write_text(text)
        for f in sources:
            shutil.copy(f, src / Path(f).name)
        for name, text in (extra_files or {}).items():
            (tmp / name).parent.mkdir(parents=True, exist_ok=True)
            (tmp / name).write_text(text)
        (tmp / "modelDescription.xml").write_text(model_description)
        lib = binary / (model_identifier + {"darwin": ".dylib", "win32": ".dll"}.get(sys.platform, ".so"))
        cmd = [cc, "-std=c99", "-O2", "-fPIC", "-shared", "-Wall", "-I", str(src), "-o", str(lib)]
        cmd += [str(src / Path(f).name) for f in sources] + ["-lm"]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            raise FMUError(f"compiling {model_identifier} failed:\n{proc.stderr.strip()}")
        with atomic_file(out, "wb") as fh, zipfile.ZipFile(fh, "w", zipfile.ZIP_DEFLATED) as z:
            for f in sorted(tmp.rglob("*")):
                if f.is_file():
                    z.write(f, f.relative_to(tmp).as_posix())
    return out
