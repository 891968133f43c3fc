"""Writing output files: atomic, only ours, never a user's file lost (see :mod:`hybridsim.files`)."""
import contextlib
import errno
import os
import re
import shutil
import tempfile
from pathlib import Path

from hybridsim.errors import OutputError
from hybridsim.files.state import (OWN, check_default_dir, output_lock, record_written, tmp_prefix,
                                   written_by_hybridsim)

_TMP = re.compile(r"^tmp-(\d+)-[A-Za-z0-9_]+$")


def _umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


def own_folder(folder):
    """``folder/.hybridsim``, created if needed (OutputError when a user's file has that name)."""
    own = Path(folder) / OWN
    if own.exists() and not own.is_dir():
        raise OutputError(f"{str(own)!r} exists and is not a folder; hybridsim keeps its temporaries "
                          "there: move it, or choose another output folder")
    own.mkdir(exist_ok=True)
    return own


def _own_temp(folder, folder_too=False):
    """A new temporary (file: ``(fd, path)``; folder: its path) in ``folder/.hybridsim``; another
    writer's removal of the empty subfolder at that moment is retried."""
    for attempt in range(3):
        own = own_folder(folder)
        try:
            if folder_too:
                return tempfile.mkdtemp(dir=own, prefix=tmp_prefix())
            return tempfile.mkstemp(dir=own, prefix=tmp_prefix())
        except FileNotFoundError:
            if attempt == 2:
                raise


def _drop_own(folder):
    """Remove ``folder/.hybridsim`` when nothing is left in it."""
    with contextlib.suppress(OSError):
        (Path(folder) / OWN).rmdir()


def check_output_dir(path):
    """Raise unless hybridsim can create or write folder ``path``: :class:`OutputError` (exit 2) for
    a path that cannot be a folder or no permission, :class:`EnvironmentProblem` (exit 5) when the
    operating system refuses (a read-only or special file system, a name too long).

    Probed by creating what is missing and removing it again, and a nameless
    temporary file: a run that fails leaves no folder behind.
    """
    from hybridsim.errors import from_os_error

    if not str(path):  # -o "": not the working folder
        raise OutputError("the output folder is empty (-o ''): give a folder, or leave -o out for the default")

    path = Path(path)
    try:
        if path.exists() and not path.is_dir():
            raise OutputError(f"output folder {str(path)!r} exists and is not a folder "
                              "(hybridsim never replaces a file with a folder); choose another -o")
        probe, missing = path, []
        while not probe.exists():
            if probe.is_symlink():  # a link to nothing: creating the folder would mean replacing it
                raise OutputError(f"cannot create output folder {str(path)!r}: {str(probe)!r} is a symbolic "
                                  "link to a missing target; hybridsim does not replace it")
            if probe.parent == probe:
                break
            missing.append(probe)
            probe = probe.parent
        if probe.exists() and not probe.is_dir():
            raise OutputError(f"cannot create output folder {str(path)!r}: {str(probe)!r} is not a folder")
        if not os.access(probe, os.W_OK | os.X_OK):  # the machine's refusal: the environment's exit code
            import errno

            code = errno.EROFS if os.statvfs(probe).f_flag & os.ST_RDONLY else errno.EACCES
            what = "write into" if probe == path else "create"
            raise from_os_error(OSError(code, os.strerror(code), str(probe)), f"cannot {what} output folder "
                                f"{str(path)!r}: writing in")
        made = []
        try:
            for folder in reversed(missing):
                folder.mkdir()
                made.append(folder)
            with tempfile.TemporaryFile(dir=path):
                pass
        finally:
            for folder in reversed(made):
                with contextlib.suppress(OSError):
                    folder.rmdir()
    except OSError as exc:  # the probe's own names are not worth showing
        raise from_os_error(OSError(exc.errno, exc.strerror), f"cannot create a file in output folder {str(path)!r}") from None
    return path


def check_output_file(path, formats=None):
    """Raise :class:`OutputError` unless file ``path`` can be written (and has a known suffix): a
    folder there, or a file hybridsim did not write, is never replaced."""
    if not str(path):
        raise OutputError("the output file is empty (-o ''): give a file name, or leave -o out for the default")
    path = Path(path)
    _refuse(path, folder=False)
    if formats is not None:
        fmt = path.suffix.lstrip(".").lower()
        if not fmt and path.name[1:].lower() in formats:  # '-o .png': a name that is all suffix
            raise OutputError(f"{str(path)!r} has no name before its suffix: give one, e.g. 'diagram{path.name}'")
        if fmt not in formats:
            raise OutputError(f"{str(path)!r}: unsupported file type {path.suffix or '(none)'!r}; "
                              f"use one of {', '.join('.' + f for f in formats)}")
    check_output_dir(path.parent if str(path.parent) else Path("."))
    return path


def make_output_dir(path):
    """Create folder ``path`` (and parents) if needed; remove our stale temporaries in it."""
    path = check_output_dir(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        from hybridsim.errors import from_os_error

        raise from_os_error(exc, f"cannot create output folder {str(path)!r}") from None
    return path


@contextlib.contextmanager
def locked_output_dir(path):
    """:func:`make_output_dir` and :func:`output_lock` together; our stale temporaries removed."""
    path = make_output_dir(path)
    with output_lock(path):
        remove_stale(path)
        yield path


def remove_stale(folder):
    """Remove temporaries hybridsim left in ``folder/.hybridsim`` from a process that no longer runs."""
    try:
        entries = list(os.scandir(Path(folder) / OWN))
    except OSError:
        return
    for e in entries:
        m = _TMP.match(e.name)
        if not m or _alive(int(m.group(1))):
            continue
        with contextlib.suppress(OSError):
            if e.is_dir(follow_symlinks=False):
                shutil.rmtree(e.path)
            else:
                os.unlink(e.path)
    _drop_own(folder)


def _alive(pid):
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    except OSError as exc:  # pragma: no cover
        return exc.errno != errno.ESRCH
    return True


@contextlib.contextmanager
def atomic_file(path, mode="w", known=False):
    """Open a temporary file (in ``.hybridsim/`` beside ``path``) that replaces ``path`` when the block
    succeeds; a ``path`` that hybridsim did not write is refused (nothing written), unless the caller
    ``known`` it as hybridsim's own (a manifest it read, in a folder copied from elsewhere)."""
    path = Path(path)
    if path.exists() and not path.is_file():
        raise OutputError(f"{str(path)!r} exists and is not a file; not replaced")
    if path.exists() and not known and not written_by_hybridsim(path):
        raise OutputError(f"{str(path)!r} exists and hybridsim did not write it; move it away or write "
                          "into another folder (nothing was written)")
    if not path.parent.is_dir():
        make_output_dir(path.parent)
    fd, tmp = _own_temp(path.parent)
    try:
        with os.fdopen(fd, mode) as fh:
            yield fh
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        _drop_own(path.parent)
        raise
    _drop_own(path.parent)
    record_written(path.parent, [path.name])


def _refuse(dst, folder):
    """Raise :class:`OutputError` where writing ``dst`` (a folder when ``folder``) would replace what
    hybridsim did not write: a file where a folder goes (or the reverse), or a user's file."""
    if folder:
        if dst.exists() and not dst.is_dir():
            raise OutputError(f"{str(dst)!r} exists and is not a folder; not replaced (nothing was written)")
    elif dst.exists() and not dst.is_file():
        raise OutputError(f"{str(dst)!r} exists and is not a file{' (it is a folder)' if dst.is_dir() else ''}; "
                          "hybridsim does not replace it (nothing was written)")
    elif dst.is_symlink():  # a file arrives by a rename, which would replace the user's link itself
        raise OutputError(f"{str(dst)!r} is a symbolic link{'' if dst.exists() else ' to a missing target'}; "
                          "hybridsim does not replace it: name its target or another file (nothing was written)")
    elif dst.exists() and not written_by_hybridsim(dst):
        raise OutputError(f"{str(dst)!r} exists and hybridsim did not write it; move it away or write "
                          "into another folder (nothing was written)")


def _check_destinations(tmp, path):
    """Refuse before anything moves (:func:`_refuse`, for every file and folder in ``tmp``)."""
    for src in sorted(tmp.rglob("*")):
        _refuse(path / src.relative_to(tmp), src.is_dir())


def check_planned(folder, names):
    """Refuse, before a long computation, the outputs it will write into ``folder`` that it may not
    replace (:func:`_refuse`); a name ending in ``/`` is a folder. The write checks them again."""
    folder = Path(folder)
    for name in names:
        _refuse(folder / name.rstrip("/"), name.endswith("/"))
    return folder


@contextlib.contextmanager
def atomic_dir(path):
    """Yield a temporary folder whose files go into folder ``path`` when the block succeeds.

    The folder is created if needed; files already in it that this run does
    not write are left alone. Every destination is checked first, then each
    file arrives by an atomic rename, under the folder's lock. On any error
    (or Ctrl-C, SIGTERM) nothing is moved and the temporary folder is
    removed; a folder created for nothing is removed too. A file there that hybridsim did not
    write is never replaced: the write is refused before anything moves.
    """
    path = Path(path)
    existed = path.is_dir()
    make_output_dir(path)
    moved = []
    try:
        tmp = Path(_own_temp(path, folder_too=True))
    except BaseException:
        _drop_own(path)
        if not existed:
            with contextlib.suppress(OSError):
                path.rmdir()
        raise
    try:
        yield tmp
        with output_lock(path):
            remove_stale(path)
            _check_destinations(tmp, path)
            mode = 0o666 & ~_umask()
            for src in sorted(tmp.rglob("*")):
                dst = path / src.relative_to(tmp)
                if src.is_dir():
                    dst.mkdir(exist_ok=True)
                    continue
                os.chmod(src, mode)
                os.replace(src, dst)
                moved.append(str(dst.relative_to(path)))
            record_written(path, [m for m in moved if "/" not in m])
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        _drop_own(path)
        if not existed:
            with contextlib.suppress(OSError):
                path.rmdir()  # only if empty: ours, made for this run
        raise
    shutil.rmtree(tmp, ignore_errors=True)
    _drop_own(path)


def output_dir(outdir, default, whole=True):
    """The output folder of a command: ``outdir`` checked (:func:`check_output_dir`), else ``default``.

    Parameters
    ----------
    outdir : path-like or None
        The folder the user gave (``-o``).
    default : path-like
        The command's default folder, used when ``outdir`` is None.
    whole : bool
        With the default folder: refuse it unless every file already in it is hybridsim's
        (:func:`~.state.check_default_dir`); else only the files a write replaces are checked, then
        (as :func:`atomic_dir` checks every folder's).

    Returns
    -------
    (pathlib.Path, bool)
        The folder, and whether it is the default (write only hybridsim's files there).
    """
    if outdir is not None and not isinstance(outdir, (str, os.PathLike)):
        raise TypeError(f"an output folder is a path (str or pathlib.Path), got {outdir!r}")
    if outdir is not None and not str(outdir):  # -o "" (an unset shell variable): not the default folder
        raise OutputError("the output folder is empty (-o ''): give a folder, or leave -o out for the default")
    if outdir:
        return check_output_dir(Path(outdir)), False
    path = check_output_dir(Path(default))
    return (check_default_dir(path) if whole else path), True
