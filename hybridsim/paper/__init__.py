"""The paper's experiment, over the engine and the blocks: Raibert & Craig (1981), Figs 7-10 and eq 18.

What is about that one experiment lives here, not in the generic layers:

* :mod:`.claims` - the claims of each figure, how each is measured, and
  :func:`~.claims.judge` (runs through :func:`hybridsim.runs.many.run_many`);
* :mod:`.hinges` - what each claim hinges on: the assumptions the paper does
  not state, varied one at a time, and the best stated model;
* :mod:`.joint_search` - every assumption at once (Optuna's TPE);
* :mod:`.reproduce` - ``hybridsim reproduce``: the damping searches, the stability
  analysis, the sensitivities; :mod:`.report` writes its page.

The model's constants (Kw, Kr, the link offset, the hand mass) are read from
the defaults of the blocks that own them, never typed again here.
"""
