"""The shipped diagrams: where they are installed, finding one by name, and a copy a user can edit.

They live in the package (``hybridsim.diagrams``: the repository's
``diagrams/`` folder), so an install from a wheel has them too and every
command works from any folder (:func:`find_diagram`). ``hybridsim examples -o DIR``
copies them (:func:`copy_examples`).
"""
import importlib.util
import shutil
from pathlib import Path

from hybridsim.errors import OutputError
from hybridsim.files import atomic_file, check_output_dir, make_output_dir


def diagrams_folder():
    """The folder of the shipped diagrams.

    Returns
    -------
    pathlib.Path
        The installed ``hybridsim/diagrams`` (or the checkout's ``diagrams/``).
    """
    spec = importlib.util.find_spec("hybridsim.diagrams")
    if spec is None or not spec.submodule_search_locations:
        raise OutputError("the shipped diagrams are not installed (hybridsim.diagrams is missing)")
    return Path(list(spec.submodule_search_locations)[0])


def shipped(name):
    """The path of a shipped diagram by file name (``"fig9_force_and_position.yaml"``).

    Parameters
    ----------
    name : str
        A file name inside the shipped diagrams folder (subfolders allowed).

    Returns
    -------
    pathlib.Path
    """
    return diagrams_folder() / name


def find_diagram(path):
    """``path``, or the shipped diagram it names when there is no such file here.

    ``diagrams/fig9_force_and_position.yaml`` (or just the file name) then works
    from any folder, as in docs/getting-started.md.

    Parameters
    ----------
    path : path-like
        A diagram, sweep or tune file.

    Returns
    -------
    (pathlib.Path, str or None)
        The file to read, and a note saying it is the shipped one (None when ``path`` is used as given).
    """
    p = Path(path)
    if p.exists():
        return p, None
    parts = p.parts[1:] if p.parts[:1] == ("diagrams",) else p.parts
    if parts and not p.is_absolute() and ".." not in parts:
        found = diagrams_folder().joinpath(*parts)
        if found.is_file():
            return found, (f"note: {path} is not here; using the shipped {found} "
                           "('hybridsim examples' copies them to edit)")
    return p, None


def copy_examples(out):
    """Copy every shipped diagram (with its subfolders) into ``out``; never replace a file.

    Parameters
    ----------
    out : path-like
        The folder to copy into (created when missing).

    Returns
    -------
    (list of pathlib.Path, list of pathlib.Path)
        The files written and the files left as they were (they existed).
    """
    out = check_output_dir(Path(out))
    src = diagrams_folder()
    files = [f for f in sorted(src.rglob("*"))
             if f.suffix.lower() in (".yaml", ".yml", ".md", ".urdf") and "__pycache__" not in f.parts]
    for f in files:  # every destination first: a folder where a file of the user's is refuses the copy
        for d in [out / p for p in f.relative_to(src).parents if str(p) != "."]:
            if (d.exists() or d.is_symlink()) and not d.is_dir():
                raise OutputError(f"{str(d)!r} is a file of yours where the examples put a folder; nothing "
                                  "was written")
    make_output_dir(out)
    written, kept = [], []
    for f in files:
        dest = out / f.relative_to(src)
        if dest.exists() or dest.is_symlink():  # a link, even one that points nowhere, is the user's
            kept.append(dest)
            continue
        dest.parent.mkdir(parents=True, exist_ok=True)
        with atomic_file(dest, "wb") as fh, open(f, "rb") as fin:
            shutil.copyfileobj(fin, fh)
        written.append(dest)
    return written, kept
