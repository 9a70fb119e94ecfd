"""The MCMC pages of one fit: corner plot, walker traces, and the posterior table beside the
least-squares optimum."""
from __future__ import annotations

import math

import corner
import emcee

from identify.fit.result import FitResult
from identify.io.fitdir import FitDir
from identify.report import tables as T
from identify.report.layout import GREY, RED, Page, draw_table, footer, new_page


def _read_chain(path):
    backend = emcee.backends.HDFBackend(str(path), name="mcmc", read_only=True)
    return backend.get_chain()  # (steps, walkers, ndim)


def _status(mc) -> str:
    if mc.converged:
        return "chain > 50 tau"
    if mc.stopped == "budget":
        return "STOPPED BY THE TIME BUDGET, CHAIN SHORTER THAN 50 TAU"
    return "CHAIN SHORTER THAN 50 TAU"


def mcmc_pages(fd: FitDir, fit: FitResult) -> tuple[list[Page], str]:
    """Corner plot, walker traces and the tau/acceptance table of one fit with MCMC."""
    mc = fit.mcmc
    if mc is None:
        return [], ""
    name = T.label(fit)
    names = list(mc.median)
    params = fit.fitted
    free = list(params)
    tau = mc.tau
    sub = (f"acceptance {T.fmt(mc.acceptance, 3)}, {mc.n_walkers} walkers x "
           f"{mc.n_steps} steps, discard {mc.n_discard}, thin {mc.n_thin}"
           f", ~{mc.n_samples} effective samples, "
           f"{_status(mc)}, "
           f"seed {mc.seed}")
    if mc.reparametrised:
        sub += f"; sampled as {', '.join(mc.reparametrised)}"
    pages: list[Page] = []
    note = ""
    chain_path = fd.chain_file(fit)
    chain = None
    if chain_path is not None:
        try:
            chain = _read_chain(chain_path)
        except Exception as exc:  # noqa: BLE001 - an unreadable chain only loses the plots
            note = f"{name}: MCMC chain {chain_path.name} unreadable ({exc})"
    else:
        note = f"{name}: MCMC chains not saved; corner plot and traces left out"
    rows = []
    for n in names:
        rows.append([n, T.fmt(params[n], 6) if n in params else "(noise)",
                     T.fmt(mc.median.get(n), 6), T.fmt(mc.q025.get(n), 5),
                     T.fmt(mc.q975.get(n), 5), T.fmt(tau.get(n), 4)])
    fig = new_page(f"MCMC {name}: posterior", sub)
    if chain is not None:
        steps, walkers, ndim = chain.shape
        labels = (free + ["log_sigma", "phi"])[:ndim] if len(names) != ndim else names
        discard = mc.n_discard
        thin = max(1, mc.n_thin)
        flat = chain[min(discard, max(steps - 1, 0))::thin].reshape(-1, ndim)
        show = list(range(min(ndim, 10)))
        try:
            corner.corner(flat[:, show], labels=[labels[i] for i in show], fig=fig,
                          quantiles=[0.025, 0.5, 0.975], show_titles=True, title_fmt=".4g",
                          title_kwargs={"fontsize": 6.5}, label_kwargs={"fontsize": 7},
                          max_n_ticks=3)
            fig.subplots_adjust(left=0.07, right=0.52, bottom=0.1, top=0.84, wspace=0.06,
                                hspace=0.06)
            for a in fig.axes:
                a.tick_params(labelsize=5.5)
            fig.text(0.07, 0.875, f"corner plot: {flat.shape[0]} samples after burn-in and "
                                  "thinning" + (f" (first {len(show)} of {ndim} parameters)"
                                                if ndim > len(show) else ""),
                     fontsize=8, va="top")
        except Exception as exc:  # noqa: BLE001 - no corner plot is a note, not a failure
            note = f"{name}: corner plot failed ({exc})"
    ax = fig.add_axes((0.56, 0.1, 0.41, 0.76) if chain is not None else (0.04, 0.08, 0.92, 0.78))
    draw_table(ax, ["parameter", "least sq.", "median", "2.5 %", "97.5 %", "tau"], rows,
               [0.3, 0.15, 0.15, 0.14, 0.14, 0.1], fontsize=7,
               title="Posterior (least-squares optimum kept apart)",
               align=["left", "right", "right", "right", "right", "right"])
    if note:
        fig.text(0.04, 0.05, note, fontsize=8, color=GREY)
    footer(fig, fd)
    pages.append((f"MCMC {name} posterior", fig))
    if chain is None:
        return pages, note
    per_page = 6
    for start in range(0, ndim, per_page):
        idx = list(range(start, min(ndim, start + per_page)))
        tfig = new_page(f"MCMC {name}: walker traces"
                        + (f" ({start // per_page + 1})" if ndim > per_page else ""), sub)
        h = 0.8 / len(idx)
        for r, i in enumerate(idx):
            ax = tfig.add_axes((0.08, 0.08 + (len(idx) - 1 - r) * h, 0.88, h - 0.02))
            ax.plot(chain[:, :, i], color="black", alpha=max(0.05, min(0.4, 8 / walkers)),
                    lw=0.5)
            ax.axvline(discard, color=RED, lw=0.8)
            ax.set_ylabel(labels[i], fontsize=7)
            ax.tick_params(labelsize=6)
            t = tau.get(labels[i], math.nan)
            if math.isfinite(t):  # fit.json writes an unknown tau as null
                ax.text(0.99, 0.9, f"tau {T.fmt(t, 3)}", transform=ax.transAxes, ha="right",
                        va="top", fontsize=7, color=GREY)
            if r < len(idx) - 1:
                ax.set_xticklabels([])
        ax.set_xlabel("step (red: burn-in discarded)")
        footer(tfig, fd)
        pages.append((f"MCMC {name} traces", tfig))
    return pages, note

