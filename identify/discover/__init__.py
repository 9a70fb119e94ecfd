"""Finding the missing effect (``mfid discover``; method in docs/discovery.md).

Modules:

- ``library`` (+ ``library.toml``): candidate effects as data, user TOML extensions;
- ``stages``: MF stage problems on trailer sweeps; ``problems``: a folder's problems and the
  base model (simplest, a .tir, a named form);
- ``noise``: the sweeps as arrays (``Sweeps``), residual autocorrelation along them, AR(1)
  prewhitening, the error model, all in one vectorised pass over the samples;
- ``objective``: (prewhitened, weighted) least squares on subsets of points;
- ``design``: condition cells and the held-out folds that fit the design;
- ``floor``: the noise floor of tables (replicates, the richest candidate model);
- ``drift``: the drift-along-the-session candidate;
- ``working``: one problem's base fit, diagnosis, noise floor, held-out folds;
- ``state``: one model state across problems (owners, readers, propagation);
- ``score``: projected score (LM) tests, testability, cosines, ambiguity groups, Holm;
- ``confirm``: refit and confirm (F test + held-out error); ``joint``: blocks of candidates
  that only generalise together;
- ``search``: the forward-stepwise loop (score -> add -> refit -> confirm -> propagate);
- ``result`` / ``conclude`` / ``finish``: frozen results, discovery.json, the conclusion;
- ``scenarios``: synthetic problems with hidden effects, the confounded table, a trailer
  session (trials, tests and benches).

Entry points: :func:`identify.discover.search.discover` (FitProblems in, a
:class:`~identify.discover.result.Discovery` out) and
:func:`identify.workflows.discover.discover_folder`.
"""
