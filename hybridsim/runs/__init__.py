"""Many runs, one way: :func:`~hybridsim.runs.many.run_many` (experiment, points, executor).

:mod:`.experiment` (a diagram parsed and built once, and the changes made to it),
:mod:`.grid` (the points), :mod:`.executor` (here, local processes or Dask),
:mod:`.store` (resuming), :mod:`.progress` (the bar), :mod:`.many` (run_many and
its measures); on them :mod:`.variants` (a diagram's ``variants:``) and
:mod:`.sweep` (sweep files, with :mod:`.table`).
"""
