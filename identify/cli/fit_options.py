"""The fit options ``mfid batch`` shares with ``mfid fit``: declared once, checked and turned
into settings.

The declarations (``McmcOption`` ... ``HoldOption``, typer's ``Annotated`` form) give both
commands the same option names and help. :func:`fit_settings` turns them into the FitSettings
of both commands after the checks (:func:`check_fit_options`): FITTYP 61 or 62, ``--mcmc-ar1``
and ``--mcmc-max-steps`` only with ``--mcmc``, a cap of at least MIN_CHECK steps.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Annotated, Any

import typer

from identify.core.errors import InputError
from identify.fit.mcmc import MAX_STEPS
from identify.fit.mcmc_steps import MIN_CHECK
from identify.fit.run import FitSettings
from identify.workflows.fit import only_names

__all__ = ["FittypOption", "FormOption", "HoldOption", "McmcAr1Option", "McmcMaxStepsOption",
           "McmcOption", "OnlyOption", "SeedOption", "check_fit_options", "fit_settings"]

McmcOption = Annotated[bool, typer.Option(
    "--mcmc", help="Run MCMC (emcee) on every fit; the chains are kept in OUT/<tyre id>/mcmc/ "
                   "for the report's corner plots and traces.")]
McmcAr1Option = Annotated[bool, typer.Option(
    "--mcmc-ar1", help="With --mcmc: AR(1) noise along each sweep.")]
McmcMaxStepsOption = Annotated[int | None, typer.Option(
    "--mcmc-max-steps", metavar="N",
    help=f"With --mcmc: cap on each chain \\[steps] (default {MAX_STEPS}). A chain stops once "
         "it is longer than 50 autocorrelation times; if the cap comes first its summary says "
         "converged = false.")]
SeedOption = Annotated[int, typer.Option("--seed", help="Seed of the global search and MCMC.")]
OnlyOption = Annotated[list[str], typer.Option(
    "--only", metavar="NAME",
    help="Fit only these relations (repeat or separate with commas): CFz, CFx, CFy, CMz, RR, "
         "camber, sidewall, MF.")]
FittypOption = Annotated[int, typer.Option("--fittyp",
                                           help="FITTYP of the written .tir: 61 or 62.")]
FormOption = Annotated[list[str], typer.Option(
    "--form", metavar="REL=FORM",
    help="Write this form of a relation whatever the data choose (repeatable): "
         "CFx|CFy=linear_load|quadratic_load, CMz=T1|T2, RR=old|new.")]
HoldOption = Annotated[list[str], typer.Option(
    "--hold", metavar="NAME",
    help="Hold this coefficient at its default in every relation fit (repeatable), e.g. one "
         "the summary reports poorly identified.")]


def check_fit_options(*, fittyp: int, mcmc: bool, mcmc_ar1: bool,
                      mcmc_max_steps: int | None) -> None:
    """Raise InputError (naming the option) for a FITTYP other than 61/62, an MCMC option
    without ``--mcmc``, or a step cap below one chunk of the chain."""
    if fittyp not in (61, 62):
        raise InputError(None, f"FITTYP must be 61 or 62, not {fittyp}", key="--fittyp")
    if mcmc_ar1 and not mcmc:
        raise InputError(None, "--mcmc-ar1 needs --mcmc", key="--mcmc-ar1")
    if mcmc_max_steps is not None and not mcmc:
        raise InputError(None, "--mcmc-max-steps needs --mcmc", key="--mcmc-max-steps")
    if mcmc_max_steps is not None and mcmc_max_steps < MIN_CHECK:
        raise InputError(None, f"--mcmc-max-steps must be at least {MIN_CHECK} (the fewest "
                               f"steps between two estimates of tau), not {mcmc_max_steps}",
                         key="--mcmc-max-steps")


def fit_settings(*, seed: int = 0, mcmc: bool = False, mcmc_ar1: bool = False,
                 mcmc_max_steps: int | None = None, only: Sequence[str] = (),
                 fittyp: int = 61, form: Sequence[str] = (),
                 hold: Sequence[str] = (), **more: Any) -> FitSettings:
    """The FitSettings of these command-line options, the same for ``mfid fit`` and
    ``mfid batch``; ``more``: further FitSettings fields (``mfid fit``'s own options).

    Raises
    ------
    InputError
        An option out of range or given without the one it needs (the key names it).
    """
    check_fit_options(fittyp=fittyp, mcmc=mcmc, mcmc_ar1=mcmc_ar1,
                      mcmc_max_steps=mcmc_max_steps)
    return FitSettings(seed=seed, mcmc=mcmc, mcmc_ar1=mcmc_ar1, save_chains=mcmc,
                       only=only_names(only), fittyp=fittyp,
                       mcmc_max_steps=mcmc_max_steps or MAX_STEPS,
                       forms=only_names(form), hold=only_names(hold), **more)
