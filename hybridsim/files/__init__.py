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
from hybridsim.files.names import safe_name, unique_names
from hybridsim.files.state import (OWN, check_default_dir, default_output_file, note_written, output_lock,
                                   record_written, state_dir, written_by_hybridsim)
from hybridsim.files.writing import (atomic_dir, atomic_file, check_output_dir, check_planned, check_output_file,
                                     locked_output_dir, make_output_dir, output_dir, own_folder, remove_stale)

__all__ = ["safe_name", "unique_names", "OWN", "check_default_dir", "default_output_file", "note_written",
           "output_lock", "record_written", "state_dir", "written_by_hybridsim", "atomic_dir", "atomic_file",
           "check_output_dir", "check_output_file", "check_planned", "locked_output_dir", "make_output_dir",
           "output_dir", "own_folder", "remove_stale"]
