"""The evaluated points of a search, one JSON line each: what makes a search resumable.

``evaluations.jsonl`` in the output folder holds every finished point keyed by
a hash of its parameter values; a second run of the same search (the seeded
optimiser asks for the same points in the same order) reads them back
instead of running them. ``tune-manifest.json`` holds a fingerprint of
everything else the numbers depend on; a different search into the same folder
is refused, or with ``force`` starts afresh (the old points kept as
``evaluations.jsonl.old``).
"""
import hashlib
import json
import math
import os
from pathlib import Path

from hybridsim.errors import InputError
from hybridsim.files import atomic_file, note_written


def point_key(values):
    """A short stable hash of ``{path: value}`` (a point's key in the store)."""
    text = json.dumps(values, sort_keys=True, default=float)
    return hashlib.sha1(text.encode()).hexdigest()[:16]


def _plain(v):
    if isinstance(v, float) and not math.isfinite(v):
        return None if math.isnan(v) else ("inf" if v > 0 else "-inf")
    return v


def _back(v):
    if v is None:
        return math.nan
    if v in ("inf", "-inf"):
        return float(v)
    return v


class Store:
    """Evaluated points of one search in ``outdir`` (see the module doc).

    Parameters
    ----------
    outdir : Path
        The output folder (made by the caller).
    fingerprint : str
        What the numbers depend on besides the point (:func:`fingerprint`).
    force : bool
        Start afresh when the folder holds another search's points.
    """

    def __init__(self, outdir, fingerprint, force=False):
        self.path = Path(outdir) / "evaluations.jsonl"
        manifest = Path(outdir) / "tune-manifest.json"
        old = json.loads(manifest.read_text()).get("fingerprint") if manifest.exists() else None
        if self.path.exists() and old != fingerprint:
            if not force:
                raise InputError(f"{outdir} holds the points of a different search (another diagram, tune "
                                 "file or hybridsim version); give another output folder, or --force to start afresh")
            os.replace(self.path, str(self.path) + ".old")
        with atomic_file(manifest, "w") as fh:
            json.dump({"fingerprint": fingerprint}, fh)
        self.done = {}
        if self.path.exists():
            for line in self.path.read_text().splitlines():
                try:
                    rec = json.loads(line)
                except json.JSONDecodeError:
                    continue  # a line cut by a crash: that point runs again
                rec["quantities"] = {k: _back(v) for k, v in rec.get("quantities", {}).items()}
                self.done[rec["key"]] = rec

    def get(self, key):
        """The stored record of ``key``, or None."""
        return self.done.get(key)

    def add(self, records):
        """Append finished records (dicts with 'key'), one line each, in one write."""
        if not records:
            return
        text = ""
        for rec in records:
            self.done[rec["key"]] = rec
            out = {**rec, "quantities": {k: _plain(v) for k, v in rec["quantities"].items()}}
            text += json.dumps(out, default=str) + "\n"
        if self.path.exists() and self.path.stat().st_size:
            with open(self.path, "rb") as fh:
                fh.seek(-1, os.SEEK_END)
                if fh.read(1) != b"\n":
                    text = "\n" + text
        with open(self.path, "a") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        note_written(self.path)


def fingerprint(spec_text, files, extra=None):
    """A hash of a tune file's text, every diagram file it runs, and the hybridsim version."""
    from hybridsim import __version__

    h = hashlib.sha256(spec_text.encode())
    for p in files:
        h.update(Path(p).read_bytes())
    h.update(json.dumps({"version": __version__, **(extra or {})}, sort_keys=True, default=str).encode())
    return h.hexdigest()[:24]
