"""Finished points kept on disk, one JSON line each: what makes many runs resumable.

A :class:`Store` is an append-only file of ``{"key": ..., "value": ...}`` lines in an
output folder (``points.jsonl`` for a sweep, ``evaluations.jsonl`` for a tune) beside a
manifest that holds the identity of everything else the values depend on
(:func:`hybridsim.format.identity.identity`: every file the runs read, the settings, the
hybridsim version and code). A second run with the same identity reads the finished points back
and runs only the others; an interrupted run loses at most the points not yet written (a
line cut by a crash is dropped and its point runs again). A store of another identity in
the folder is refused, or with ``restart`` set aside (``NAME.old``) and started afresh.
"""
import json
import os
from pathlib import Path

from hybridsim.errors import InputError, OutputError
from hybridsim.files import atomic_file, note_written


class Store:
    """The finished points of one job in ``folder`` (see the module doc).

    Parameters
    ----------
    folder : Path
        The output folder (made, and locked where that matters, by the caller).
    identity : str
        What the values depend on besides their point (:func:`~hybridsim.format.identity.identity`).
    name : str
        The file of points, e.g. ``points.jsonl``.
    manifest : str
        The file that holds ``identity``, e.g. ``sweep-manifest.json``.
    what : str
        What a point belongs to, for the message that refuses another's ("sweep", "search").
    changed : str
        What may have changed, for that message.
    restart : bool
        Set another job's points aside and start afresh instead of refusing.
    about : dict, optional
        More to write into the manifest (what the job was: its file, its diagram).
    """

    def __init__(self, folder, identity, name, manifest, what, changed, restart=False, about=None):
        folder = Path(folder)
        self.path, self.what = folder / name, what
        self.set_aside = None  # where --force put another job's points (their traces go beside them)
        manifest = folder / manifest
        for f in (self.path, manifest):  # before anything is renamed
            if f.is_symlink() or (f.exists() and not f.is_file()):
                raise OutputError(f"{str(f)!r} is {'a symbolic link' if f.is_symlink() else 'not a file'}; "
                                  "hybridsim does not write through it: move it away (nothing was written)")
        old, said = None, {}
        if manifest.exists():
            try:
                said = json.loads(manifest.read_text())
                old = said.get("fingerprint")
            except (OSError, ValueError, AttributeError):
                old, said = "unreadable", {}
        if self.path.exists() and self.path.stat().st_size and old != identity:
            why = f"no {manifest.name} says which {what} they belong to" if old is None else changed
            if not restart:
                raise InputError(f"{folder} holds points of a different {what} ({why}); they would not match "
                                 f"this one. Use another output folder (-o), or --force to start afresh (the old "
                                 f"points are kept as {aside(self.path).name})")
            self._set_aside(name)
        now = json.loads(json.dumps({"fingerprint": identity, **(about or {})}, default=str))
        if old != identity or said != now:  # (the job's file named anew); a manifest it read is hybridsim's
            with atomic_file(manifest, known=isinstance(old, str) and old != "unreadable") as fh:
                json.dump({"fingerprint": identity, **(about or {})}, fh, indent=1, default=str)
        self.done = {}
        if self.path.exists():
            try:
                text = self.path.read_text()
            except UnicodeDecodeError:
                if not restart:
                    raise InputError(f"{self.path} is not a file of points hybridsim wrote (not UTF-8 text); use "
                                     f"another output folder (-o), or --force to start afresh (it is kept as "
                                     f"{aside(self.path).name})") from None
                self._set_aside(name)
                text = ""
            for line in text.splitlines():
                try:
                    rec = json.loads(line)
                    self.done[rec["key"]] = rec["value"]
                except (json.JSONDecodeError, KeyError, TypeError):
                    continue  # a line cut by a crash (or of an older layout): that point runs again

    def _set_aside(self, name):
        """Rename the points file to the first free ``NAME.old``, ``NAME.old.1``, ... (--force): every
        earlier generation is kept."""
        old = aside(self.path)
        os.replace(self.path, old)
        note_written(old)
        self.set_aside = old

    def __contains__(self, key):
        return key in self.done

    def get(self, key, default=None):
        """The stored value of ``key``, or ``default``."""
        return self.done.get(key, default)

    def add(self, values):
        """Append ``{key: value}`` (JSON-able values), one line each, in one write and one fsync."""
        if not values:
            return
        text = "".join(json.dumps({"key": k, "value": v}, default=_jsonable) + "\n" for k, v in values.items())
        if self.path.exists() and self.path.stat().st_size:
            with open(self.path, "rb") as fh:
                fh.seek(-1, os.SEEK_END)
                if fh.read(1) != b"\n":  # a line cut by a crash: start ours on a fresh line
                    text = "\n" + text
        with open(self.path, "a") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        note_written(self.path)
        self.done.update(values)


def _jsonable(v):
    import numpy as np

    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    if isinstance(v, np.bool_):
        return bool(v)
    if isinstance(v, np.ndarray):
        return v.tolist()
    return str(v)


def aside(path):
    """The first of ``NAME.old``, ``NAME.old.1``, ... beside ``path`` that names nothing."""
    k = 0
    while True:
        old = path.with_name(path.name + (".old" if k == 0 else f".old.{k}"))
        if not (old.exists() or old.is_symlink()):
            return old
        k += 1
