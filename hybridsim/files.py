"""Output files: atomic, only ours, never a user's file lost.

* Every file is written to a temporary name in its folder and renamed into
  place (``os.replace`` is atomic), so a reader never sees half a result.
* An output folder may be the user's own: hybridsim writes the files of this
  run into it and touches nothing else (no deleting, no mode change). A path
  that exists and is not a folder is refused (:class:`OutputError`).
* Temporaries live in hybridsim's own subfolder of the output folder,
  ``.hybridsim/`` (``tmp-PID-XXXX``), removed (with the subfolder, once
  empty) when the write ends, on errors, Ctrl-C and SIGTERM; the next write
  into the folder removes those whose process is gone (after a SIGKILL).
  Nothing outside ``.hybridsim/`` is ever removed, and no name in the user's
  folder is matched against a pattern.
* hybridsim's state folder (``$HYBRIDSIM_CACHE``, else ``~/.cache/hybridsim``)
  records a hash of each file hybridsim wrote, so a default output name
  (``hybridsim draw d.yaml`` without ``-o``) replaces only a file hybridsim
  wrote (:func:`default_output_file`), and holds the output folders' locks:
  one writer per folder at a time (:func:`output_lock`); a second is refused
  before it changes anything.
* Every destination is checked before the first file moves into place, so a
  refused write leaves the folder as it was.
* Names that come from a diagram become file names only through
  :func:`safe_name` (no separators, no ``..``).
* Files get the mode the user's umask gives (as ``open`` would), not 0600.
"""
import contextlib
import errno
import hashlib
import os
import re
import shutil
import tempfile
from pathlib import Path

from hybridsim.errors import OutputError

OWN = ".hybridsim"  # hybridsim's own subfolder of an output folder
_TMP = re.compile(r"^tmp-(\d+)-[A-Za-z0-9_]+$")


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


def _tmp_prefix():
    return f"tmp-{os.getpid()}-"


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
                return tempfile.mkdtemp(dir=own, prefix=_tmp_prefix())
            return tempfile.mkstemp(dir=own, prefix=_tmp_prefix())
        except FileNotFoundError:
            if attempt == 2:
                raise


def _drop_own(folder):
    """Remove ``folder/.hybridsim`` when nothing is left in it."""
    with contextlib.suppress(OSError):
        (Path(folder) / OWN).rmdir()


def state_dir(kind):
    """hybridsim's state folder ``kind`` (``written``, ``locks``): under ``$HYBRIDSIM_CACHE``, else
    ``$XDG_CACHE_HOME/hybridsim`` or ``~/.cache/hybridsim``; a private temporary folder if none is writable."""
    root = os.environ.get("HYBRIDSIM_CACHE") or Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "hybridsim"
    for base in (Path(root), Path(tempfile.gettempdir()) / f"hybridsim-{os.getuid()}"):
        try:
            (base / kind).mkdir(parents=True, exist_ok=True)
            if os.access(base / kind, os.W_OK):
                return base / kind
        except OSError:
            continue
    raise OutputError("hybridsim has no writable state folder: set HYBRIDSIM_CACHE to a writable folder")


def _key(path):
    return hashlib.sha256(str(Path(path).resolve()).encode()).hexdigest()[:32]


def _digest(path):
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _record(folder, names):
    """Note (in the state folder) the hashes of the files ``names`` just written into ``folder``."""
    try:
        book = state_dir("written")
    except OutputError:
        return
    for n in names:
        with contextlib.suppress(OSError):
            target = Path(folder) / n
            fd, tmp = tempfile.mkstemp(dir=book, prefix=_tmp_prefix())
            with os.fdopen(fd, "w") as fh:
                fh.write(_digest(target))
            os.replace(tmp, book / _key(target))


def written_by_hybridsim(path):
    """Whether the file ``path`` is, byte for byte, the one hybridsim last wrote there."""
    try:
        return (state_dir("written") / _key(path)).read_text().strip() == _digest(path)
    except (OSError, OutputError):
        return False


def note_written(path):
    """Record that hybridsim has just written (or appended to) the file ``path``."""
    path = Path(path)
    _record(path.parent, [path.name])


def check_default_dir(folder):
    """A default output folder (no ``-o``) may be written only when every file in it is one
    hybridsim wrote there: else :class:`OutputError`, before any work, naming the first other file."""
    folder = Path(folder)
    if not folder.is_dir():
        return folder
    for p in sorted(folder.rglob("*")):
        if OWN in p.relative_to(folder).parts or not p.is_file():
            continue
        if not written_by_hybridsim(p):
            raise OutputError(f"{str(p)!r} exists and hybridsim did not write it; {folder} is this "
                              "command's default output folder: give -o to write into it anyway, or "
                              "choose another (nothing was written)")
    return folder


def default_output_file(path):
    """``(path, note)``: the file a default output name may write, never a file hybridsim did not write.

    ``path`` itself when it does not exist or hybridsim wrote it; else the
    first free ``NAME-2.EXT``, ``NAME-3.EXT``, ... with a note saying so.
    """
    path = Path(path)
    if not path.exists() or (path.is_file() and written_by_hybridsim(path)):
        return path, None
    for k in range(2, 1000):
        alt = path.with_name(f"{path.stem}-{k}{path.suffix}")
        if not alt.exists() or (alt.is_file() and written_by_hybridsim(alt)):
            return alt, (f"note: {path} exists and hybridsim did not write it; writing {alt} instead "
                         "(-o chooses the name)")
    raise OutputError(f"{path} and its numbered alternatives exist; choose a name with -o")


@contextlib.contextmanager
def output_lock(folder):
    """Hold ``folder``'s lock (in the state folder) for the block: one writer per folder at a time.

    Raises OutputError (exit 2) at once, having changed nothing, while
    another process holds it.
    """
    import fcntl

    fd = os.open(state_dir("locks") / f"{_key(folder)}.lock", os.O_RDWR | os.O_CREAT, 0o666)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
            raise OutputError(f"another hybridsim (process {holder}) is writing into {str(folder)!r}; "
                              "wait for it to finish or choose another output folder (-o)") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, str(os.getpid()).encode(), 0)
        yield Path(folder)
    finally:
        os.close(fd)  # releases the lock


def check_output_dir(path):
    """Raise unless hybridsim can create or write folder ``path``: :class:`OutputError` (exit 2) for
    a path that cannot be a folder or no permission, :class:`EnvironmentProblem` (exit 5) when the
    operating system refuses (a read-only or special file system, a name too long).

    Probed by creating what is missing and removing it again, and a nameless
    temporary file: a run that fails leaves no folder behind.
    """
    from hybridsim.errors import from_os_error

    path = Path(path)
    try:
        if path.exists() and not path.is_dir():
            raise OutputError(f"output folder {str(path)!r} exists and is not a folder "
                              "(hybridsim never replaces a file with a folder); choose another -o")
        probe, missing = path, []
        while not probe.exists():
            if probe.parent == probe:
                break
            missing.append(probe)
            probe = probe.parent
        if probe.exists() and not probe.is_dir():
            raise OutputError(f"cannot create output folder {str(path)!r}: {str(probe)!r} is not a folder")
        if not os.access(probe, os.W_OK | os.X_OK):
            what = "write into" if probe == path else "create"
            raise OutputError(f"cannot {what} output folder {str(path)!r}: "
                              f"no permission to write in {str(probe)!r}")
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
        raise from_os_error(OSError(exc.errno, exc.strerror), f"cannot write output folder {str(path)!r}") from None
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
def atomic_file(path, mode="w"):
    """Open a temporary file (in ``.hybridsim/`` beside ``path``) that replaces ``path`` when the block succeeds."""
    path = Path(path)
    if path.exists() and not path.is_file():
        raise OutputError(f"{str(path)!r} exists and is not a file; not replaced")
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
    _record(path.parent, [path.name])


def _check_destinations(tmp, path, only_ours):
    """Refuse before anything moves: a file whose place is a folder (or the reverse), and with
    ``only_ours`` a file there that hybridsim did not write."""
    for src in sorted(tmp.rglob("*")):
        dst = path / src.relative_to(tmp)
        if src.is_dir():
            if dst.exists() and not dst.is_dir():
                raise OutputError(f"{str(dst)!r} exists and is not a folder; not replaced (nothing was written)")
        elif dst.is_dir():
            raise OutputError(f"{str(dst)!r} is a folder; hybridsim does not replace it with a file "
                              "(nothing was written)")
        elif only_ours and dst.exists() and not written_by_hybridsim(dst):
            raise OutputError(f"{str(dst)!r} exists and hybridsim did not write it; give -o to write "
                              "into this folder anyway, or choose another (nothing was written)")


@contextlib.contextmanager
def atomic_dir(path, only_ours=False):
    """Yield a temporary folder whose files go into folder ``path`` when the block succeeds.

    The folder is created if needed; files already in it that this run does
    not write are left alone. Every destination is checked first, then each
    file arrives by an atomic rename, under the folder's lock. On any error
    (or Ctrl-C, SIGTERM) nothing is moved and the temporary folder is
    removed; a folder created for nothing is removed too. ``only_ours``
    (a default output folder): refuse to replace a file hybridsim did not write.
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
            _check_destinations(tmp, path, only_ours)
            mode = 0o666 & ~_umask()
            for src in sorted(tmp.rglob("*")):
                dst = path / src.relative_to(tmp)
                if src.is_dir():
                    dst.mkdir(exist_ok=True)
                    continue
                os.chmod(src, mode)
                os.replace(src, dst)
                moved.append(str(dst.relative_to(path)))
            _record(path, [m for m in moved if "/" not in m])
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        _drop_own(path)
        if not existed:
            with contextlib.suppress(OSError):
                path.rmdir()  # only if empty: ours, made for this run
        raise
    shutil.rmtree(tmp, ignore_errors=True)
    _drop_own(path)


def unique_names(labels, stem, default="run"):
    """File stems for ``labels`` (run labels) that cannot collide: ``stem_slug``, with a short hash of
    the label where two slugs (or a slug and ``stem`` itself) would be the same name (case-folded)."""
    slugs = [(stem + "_" + _slug(lab, default)) if lab else stem for lab in labels]
    seen = {}
    for s in slugs:
        seen[s.lower()] = seen.get(s.lower(), 0) + 1
    out = []
    for lab, s in zip(labels, slugs):
        if seen[s.lower()] > 1:
            s = f"{s}_{hashlib.sha1(str(lab).encode()).hexdigest()[:6]}"
        out.append(s)
    return out


def _slug(label, default="run"):
    return safe_name("".join(c if c.isalnum() or c in "-." else "-" for c in str(label).replace("=", "")), default)
