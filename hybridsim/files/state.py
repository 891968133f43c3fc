"""hybridsim's own places: the ``.hybridsim`` subfolder of an output folder and the state folder.

The state folder (``$HYBRIDSIM_CACHE``, else ``~/.cache/hybridsim``) holds a hash
of each file hybridsim wrote - so a default output name replaces only such a
file - and the output folders' locks, one writer per folder at a time.
"""
import contextlib
import hashlib
import os
import tempfile
from pathlib import Path

from hybridsim.errors import OutputError

OWN = ".hybridsim"  # hybridsim's own subfolder of an output folder


def tmp_prefix():
    """The name prefix of this process's temporaries, ``tmp-PID-``."""
    return f"tmp-{os.getpid()}-"


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


def record_written(folder, names):
    """Note (in the state folder) the hashes of the files ``names`` just written into ``folder``."""
    try:
        book = state_dir("written")
    except OutputError:
        return
    for n in names:
        with contextlib.suppress(OSError):
            target = Path(folder) / n
            fd, tmp = tempfile.mkstemp(dir=book, prefix=tmp_prefix())
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
    record_written(path.parent, [path.name])


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
