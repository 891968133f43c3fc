"""Output files: atomic, only ours, never a user's file lost.

* Every file is written to a temporary name in its folder and renamed into
  place (``os.replace`` is atomic), so a reader never sees half a result.
* An output folder may be the user's own: hybridsim writes the files of this
  run into it and touches nothing else (no deleting, no mode change). A path
  that exists and is not a folder is refused (:class:`OutputError`).
* Temporary names carry the writer's process id
  (``.NAME.hybridsim-PID-XXXX.tmp``); they are removed on errors, Ctrl-C and
  SIGTERM, and the next run into the folder removes those whose process is gone
  (after a SIGKILL). Nothing else is ever removed.
* Names that come from a diagram become file names only through
  :func:`safe_name` (no separators, no ``..``).
* Files get the mode the user's umask gives (as ``open`` would), not 0600.
"""
import contextlib
import errno
import os
import re
import shutil
import tempfile
from pathlib import Path

from .errors import OutputError

_TMP = re.compile(r"^\..*\.hybridsim-(\d+)-[A-Za-z0-9_]+\.tmp$")


def safe_name(name, default="diagram"):
    """``name`` as a plain file name: letters, digits, ``-_.+=,``; no path, no leading dot.

    >>> safe_name("../../x")
    'x'
    """
    text = re.sub(r"[^A-Za-z0-9_.+=,-]+", "-", str(name))
    text = text.strip(".-")
    return text[:120] or default


def _umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _tmp_prefix(name):
    return f".{name}.hybridsim-{os.getpid()}-"


def check_output_dir(path):
    """Raise :class:`OutputError` unless hybridsim can create or write folder ``path``.

    Nothing is created: a run that fails leaves no folder behind.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise OutputError(f"output folder {str(path)!r} exists and is not a folder "
                          "(hybridsim never replaces a file with a folder); choose another -o")
    probe = path
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    if probe.exists() and not probe.is_dir():
        raise OutputError(f"cannot create output folder {str(path)!r}: {str(probe)!r} is not a folder")
    if not os.access(probe, os.W_OK | os.X_OK):
        what = "write into" if probe == path else "create"
        raise OutputError(f"cannot {what} output folder {str(path)!r}: "
                          f"no permission to write in {str(probe)!r}")
    return path


def check_output_file(path, formats=None):
    """Raise :class:`OutputError` unless file ``path`` can be written (and has a known suffix)."""
    path = Path(path)
    if path.exists() and not path.is_file():
        raise OutputError(f"{str(path)!r} exists and is not a file; hybridsim does not replace it")
    if formats is not None:
        fmt = path.suffix.lstrip(".").lower()
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
        raise OutputError(f"cannot create output folder {str(path)!r}: {exc.strerror}") from None
    remove_stale(path)
    return path


def remove_stale(folder):
    """Remove temporaries hybridsim left in ``folder`` from a process that no longer runs."""
    try:
        entries = list(os.scandir(folder))
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
def atomic_file(path, mode="w"):
    """Open a temporary file that replaces ``path`` when the block succeeds."""
    path = Path(path)
    if path.exists() and not path.is_file():
        raise OutputError(f"{str(path)!r} exists and is not a file; not replaced")
    if not path.parent.is_dir():
        make_output_dir(path.parent)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=_tmp_prefix(path.name), suffix=".tmp")
    try:
        with os.fdopen(fd, mode) as fh:
            yield fh
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


@contextlib.contextmanager
def atomic_dir(path):
    """Yield a temporary folder whose files go into folder ``path`` when the block succeeds.

    The folder is created if needed; files already in it that this run does
    not write are left alone. Each file arrives by an atomic rename. On any
    error (or Ctrl-C, SIGTERM) nothing is moved and the temporary folder is
    removed; a folder created for nothing is removed too.
    """
    path = Path(path)
    existed = path.is_dir()
    make_output_dir(path)
    tmp = Path(tempfile.mkdtemp(dir=path, prefix=_tmp_prefix("out"), suffix=".tmp"))
    try:
        yield tmp
        mode = 0o666 & ~_umask()
        for src in sorted(tmp.rglob("*")):
            dst = path / src.relative_to(tmp)
            if src.is_dir():
                if dst.exists() and not dst.is_dir():
                    raise OutputError(f"{str(dst)!r} exists and is not a folder; not replaced")
                dst.mkdir(exist_ok=True)
                continue
            if dst.is_dir():
                raise OutputError(f"{str(dst)!r} is a folder; hybridsim does not replace it with a file")
            os.chmod(src, mode)
            os.replace(src, dst)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        if not existed:
            with contextlib.suppress(OSError):
                path.rmdir()  # only if empty: ours, made for this run
        raise
    shutil.rmtree(tmp, ignore_errors=True)
