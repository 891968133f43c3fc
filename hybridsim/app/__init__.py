"""The ``hybridsim`` command line: one module per command over the Python API (:mod:`.cli` assembles them)."""
