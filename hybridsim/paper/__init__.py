"""The paper's experiment, over the engine and the blocks: Raibert & Craig (1981), Figs 7-10 and eq 18.

What is about that one experiment lives here, not in the generic layers:

* :mod:`.reproduce` - the claims of each figure, how each is measured, the
  damping searches and the ``hybridsim reproduce`` report;
* :mod:`.hinges` - what each claim hinges on: the assumptions the paper does
  not state, varied one at a time, and the best stated model.

The model's constants (Kw, Kr, the link offset, the hand mass) are read from
the defaults of the blocks that own them, never typed again here.
"""
