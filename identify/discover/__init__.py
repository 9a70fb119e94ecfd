"""Finding the missing effect (``mfid discover``; method in docs/discovery.md).

Modules:

- ``library`` (+ ``library.toml``): candidate effects as data, user TOML extensions;
- ``stages``: MF stage problems on trailer sweeps; ``problems``: a folder's problems and the
  base model (simplest, a .tir, a named form);
- ``noise``: residual autocorrelation along sweeps, AR(1) prewhitening, the error model;
- ``objective``: (prewhitened, weighted) least squares on subsets of points;
- ``working``: one problem's base fit, diagnosis, noise floor, held-out folds;
- ``score``: projected score (LM) tests, testability, cosines, ambiguity groups, Holm;
- ``search``: the forward-stepwise loop (score -> add -> refit -> F test + held-out error);
- ``result`` / ``conclude``: frozen results, discovery.json, the plain conclusion;
- ``report``: the PDF; ``run``: folder in, ``fits/<tyre id>/discovery/`` out;
- ``scenarios``: synthetic problems with a hidden effect (trials and tests).

Entry points: :func:`identify.discover.search.discover` (FitProblems in, a
:class:`~identify.discover.result.Discovery` out) and
:func:`identify.workflows.discover.discover_folder`.
"""
