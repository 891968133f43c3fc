"""Design by search: tune run-time parameters of a diagram against objectives and constraints.

A tune file (beside the sweep format, :mod:`hybridsim.runs.sweep`) names a diagram,
the parameters to search with their bounds, the objectives (a run's metrics,
a step response's measures, the linearized loop's largest ``|z|`` and margins) and the
constraints on the same quantities, and the optimiser. :func:`run_tune` does
what ``hybridsim tune`` does; see docs/tune.md.

Modules: :mod:`.space` (parameters and their scales), :mod:`.spec` (the tune
file), :mod:`.quantities` (what is measured at a point), :mod:`.drivers` (the
optimisers), :mod:`.outputs` (overlay, tables, plots), :mod:`.run` (the whole
command). The points run through :func:`hybridsim.runs.many.run_many`, with its
executor and resume store (``evaluations.jsonl``).
"""
from hybridsim.tune.run import evaluate_point, run_tune
from hybridsim.tune.spec import TuneSpec, load_tune

