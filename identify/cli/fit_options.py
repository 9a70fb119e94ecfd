"""The fit options ``mfid batch`` shares with ``mfid fit``: declared once, checked and turned
into settings.

The declarations (``McmcOption`` ... ``NoRevolutionAverageOption``, typer's ``Annotated``
form) give both commands the same option names and help: every option that changes a fit is
one of them (``mfid fit``'s own are only those of a single characteristics CSV, which
``mfid batch`` does not take). :func:`fit_settings` turns them into the FitSettings of both
commands after the checks (:func:`check_fit_options`): FITTYP 61 or 62, ``--mcmc-ar1``,
``--mcmc-max-steps`` and ``--mcmc-budget`` only with ``--mcmc``, a cap of at least MIN_CHECK
steps, a positive budget, positive bin widths and no bin width with ``--no-bin``.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Annotated, Any

import typer

from identify.core.errors import InputError
from identify.fit.mcmc.chains import BUDGET_S, MAX_STEPS
from identify.fit.mcmc.steps import MIN_CHECK
from identify.fit.run import FitSettings
from identify.workflows.fit import only_names

__all__ = ["BinAlphaOption", "BinKappaOption", "FittypOption", "FormOption", "HoldOption",
           "McmcAr1Option", "McmcBudgetOption", "McmcMaxStepsOption", "McmcOption",
           "NoBinOption", "NoRevolutionAverageOption", "NoSegmentOption", "OnlyOption",
           "PressureHoldoutOption",
           "SeedOption", "check_fit_options", "fit_settings"]

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
McmcBudgetOption = Annotated[float | None, typer.Option(
    "--mcmc-budget", metavar="SECONDS",
    help="With --mcmc: wall-time budget in seconds of the whole MCMC run of one tyre, all chains "
         f"together (default {BUDGET_S:g}; 'inf' for none). The chains run after the fits, "
         "cheapest first; each may use the budget left divided by the chains left, so time a "
         "chain does not need goes to the later ones. A chain stops at 50 autocorrelation "
         "times, the step cap or its share, whichever comes first; stopped early, it says "
         "converged = false and a warning names it with its steps and tau.")]
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
BinAlphaOption = Annotated[float | None, typer.Option(
    "--bin-alpha", metavar="DEG",
    help="Bin width \\[deg] of dense slip-angle sweeps of trailer data: every sweep with at "
         "least 3 samples per bin is averaged per bin before the MF stages (default 0.25; "
         "docs/procedures.md, 'Sweep binning', states the effect).")]
BinKappaOption = Annotated[float | None, typer.Option(
    "--bin-kappa", metavar="K", help="Bin width [-] of dense slip-ratio sweeps (default 0.0025).")]
NoBinOption = Annotated[bool, typer.Option(
    "--no-bin", help="Fit every trailer sample: no sweep binning.")]
NoSegmentOption = Annotated[bool, typer.Option(
    "--no-segment",
    help="Fit trailer runs with a warm-up (logged test programmes such as a TTC session) on all "
         "their samples, not on their quasi-steady sweeps only.")]
NoRevolutionAverageOption = Annotated[bool, typer.Option(
    "--no-revolution-average",
    help="Do not average trailer samples over one wheel revolution before the bins: for a tyre "
         "whose curve changes within a revolution (a sharp Fx peak at a small slip ratio) when "
         "the ripple is the wheel's load variation, which the forces follow "
         "(docs/intervals.md, 'What the averaging does').")]

PressureHoldoutOption = Annotated[bool, typer.Option(
    "--pressure-holdout/--no-pressure-holdout",
    help="Predict each pressure level of the MF fit by the force and moment stages fitted "
         "again without it (the report's pressure page; on by default): a local refit per "
         "level, shared with a worker process. --no-pressure-holdout leaves the page "
         "empty and saves that time.")]


def check_fit_options(*, fittyp: int, mcmc: bool, mcmc_ar1: bool,
                      mcmc_max_steps: int | None, mcmc_budget: float | None = None,
                      bin_alpha: float | None = None, bin_kappa: float | None = None,
                      no_bin: bool = False) -> None:
    """Raise InputError (naming the option) for a FITTYP other than 61/62, an MCMC option
    without ``--mcmc``, a step cap below one chunk of the chain, a budget that is not a
    positive number of seconds, a bin width that is not positive or given with
    ``--no-bin``."""
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
    if mcmc_budget is not None and not mcmc:
        raise InputError(None, "--mcmc-budget needs --mcmc", key="--mcmc-budget")
    if mcmc_budget is not None and not mcmc_budget > 0:
        raise InputError(None, f"--mcmc-budget must be a positive number of seconds (or "
                               f"inf), not {mcmc_budget:g}", key="--mcmc-budget")
    if no_bin and (bin_alpha is not None or bin_kappa is not None):
        raise InputError(None, "--no-bin and --bin-alpha/--bin-kappa contradict each other",
                         key="--no-bin")
    for key, width in (("--bin-alpha", bin_alpha), ("--bin-kappa", bin_kappa)):
        if width is not None and not (width > 0 and math.isfinite(width)):
            raise InputError(None, f"{key} must be a positive number, not {width:g}", key=key)


def fit_settings(*, seed: int = 0, mcmc: bool = False, mcmc_ar1: bool = False,
                 mcmc_max_steps: int | None = None, only: Sequence[str] = (),
                 fittyp: int = 61, form: Sequence[str] = (),
                 hold: Sequence[str] = (), mcmc_budget: float | None = None,
                 bin_alpha: float | None = None, bin_kappa: float | None = None,
                 no_bin: bool = False, no_segment: bool = False,
                 no_revolution_average: bool = False, pressure_holdout: bool = True,
                 **more: Any) -> FitSettings:
    """The FitSettings of these command-line options, the same for ``mfid fit`` and
    ``mfid batch``; ``more``: further FitSettings fields (``mfid fit``'s own options).

    Raises
    ------
    InputError
        An option out of range or given without the one it needs (the key names it).
    """
    check_fit_options(fittyp=fittyp, mcmc=mcmc, mcmc_ar1=mcmc_ar1,
                      mcmc_max_steps=mcmc_max_steps, mcmc_budget=mcmc_budget,
                      bin_alpha=bin_alpha, bin_kappa=bin_kappa, no_bin=no_bin)
    bins = {"bin_alpha_deg": None, "bin_kappa": None} if no_bin else {
        k: v for k, v in (("bin_alpha_deg", bin_alpha), ("bin_kappa", bin_kappa))
        if v is not None}
    budget = (BUDGET_S if mcmc_budget is None else None if math.isinf(mcmc_budget)
              else mcmc_budget)
    return FitSettings(seed=seed, mcmc=mcmc, mcmc_ar1=mcmc_ar1, save_chains=mcmc,
                       only=only_names(only), fittyp=fittyp,
                       mcmc_max_steps=mcmc_max_steps or MAX_STEPS, mcmc_budget_s=budget,
                       forms=only_names(form), hold=only_names(hold),
                       segment=not no_segment, revolution_average=not no_revolution_average,
                       pressure_holdout=pressure_holdout,
                       **bins, **more)
