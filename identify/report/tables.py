"""The report's tables as plain rows (no plotting): fit summary, thesis error per pressure,
parameters with intervals, data-quality flags and fit diagnostics.

The same rows feed the PDF pages and the ``mfid fit`` summary on the terminal.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Iterable, Mapping

Z95 = 1.959963984540054
"""Two-sided 95 % quantile of the standard normal (value +/- Z95 * standard error)."""


def num(x: Any) -> float:
    """float(x), NaN for None or anything not a number."""
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def fmt(x: Any, digits: int = 4) -> str:
    """A number with ``digits`` significant digits; "n/a" for NaN/None."""
    v = num(x)
    if not math.isfinite(v):
        return "n/a" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    return f"{v:.{digits}g}"


def fmt_pct(x: Any) -> str:
    v = num(x)
    if not math.isfinite(v):
        return "n/a"
    return f"{v:.3f}" if abs(v) < 100 else f"{v:.1f}"


def label(fit: Mapping[str, Any]) -> str:
    """``relation [form]``."""
    return f"{fit.get('relation')} [{fit.get('form')}]"


def source_tag(fit: Mapping[str, Any]) -> str:
    """The key_sources value a fit's .tir keys carry (``relation/form``, MF stages
    ``MF/<stage> (trailer)``)."""
    return f"{fit.get('relation')}/{fit.get('form')}"


def tir_keys(fit: Mapping[str, Any], key_sources: Mapping[str, str]) -> list[str]:
    """The .tir keys this fit supplied."""
    tag = source_tag(fit)
    return sorted(k for k, src in key_sources.items()
                  if src == tag or src.startswith(tag + " "))


# ----- summary ---------------------------------------------------------------------------------

@dataclass(frozen=True)
class SummaryRow:
    relation: str
    form: str
    error_total_pct: float
    n_points: int
    converged: bool
    in_tir: bool
    key_coefficients: str


def key_coefficients(fit: Mapping[str, Any], limit: int = 4) -> str:
    """The free parameters as ``NAME=value`` (``limit`` of them, then "+n more")."""
    params = fit.get("parameters") or {}
    items = [f"{k}={fmt(v)}" for k, v in params.items()]
    if len(items) > limit:
        items = items[:limit] + [f"+{len(params) - limit} more"]
    return ", ".join(items)


def summary_rows(doc: Mapping[str, Any]) -> list[SummaryRow]:
    """One row per fit of fit.json, in fit order."""
    key_sources = (doc.get("tir") or {}).get("key_sources") or {}
    out = []
    for fit in doc.get("fits") or []:
        out.append(SummaryRow(str(fit.get("relation")), str(fit.get("form")),
                              num(fit.get("error_total_pct")), int(fit.get("n_points") or 0),
                              bool(fit.get("converged")), bool(tir_keys(fit, key_sources)),
                              key_coefficients(fit)))
    return out


# ----- thesis error table ----------------------------------------------------------------------

def error_rows(fit: Mapping[str, Any]) -> list[tuple[str, str]]:
    """The thesis error table as the thesis lays it out: total first, then one row per
    pressure (ascending). Values in %."""
    by_p = fit.get("error_by_pressure_pct") or {}
    rows = [("total (mean)", fmt_pct(fit.get("error_total_pct")))]
    for key in sorted(by_p, key=num):
        rows.append((f"{num(key):g} bar", fmt_pct(by_p[key])))
    return rows


# ----- parameter table -------------------------------------------------------------------------

@dataclass(frozen=True)
class ParamRow:
    """One free parameter: least-squares value and standard error, a 95 % interval, bounds."""

    name: str
    value: float
    stderr: float
    lo95: float
    hi95: float
    interval: str            # "MCMC 2.5-97.5 %" or "LS +/-1.96 s.e."
    lower: float
    upper: float
    at_bound: bool
    in_tir: bool
    median: float = math.nan  # MCMC posterior median (NaN without MCMC)


def parameter_rows(fit: Mapping[str, Any], key_sources: Mapping[str, str] | None = None
                   ) -> list[ParamRow]:
    """The free parameters with value, standard error, 95 % interval, bounds and flags.

    The interval is the MCMC 2.5-97.5 % posterior quantiles when the fit has an MCMC
    summary for the parameter, else value +/- 1.96 standard errors (labelled as such).
    """
    params = fit.get("parameters") or {}
    stderr = fit.get("stderr") or {}
    bounds = fit.get("bounds") or {}
    at_bound = set(fit.get("at_bound") or ())
    mc = fit.get("mcmc") or {}
    q025, q975, med = mc.get("q025") or {}, mc.get("q975") or {}, mc.get("median") or {}
    keys = set(tir_keys(fit, key_sources or {}))
    rows = []
    for name, value in params.items():
        v, se = num(value), num(stderr.get(name))
        if name in q025 and name in q975:
            lo, hi, how = num(q025[name]), num(q975[name]), "MCMC 2.5-97.5 %"
        else:
            lo, hi, how = v - Z95 * se, v + Z95 * se, "LS +/-1.96 s.e."
        b = bounds.get(name) or (None, None)
        rows.append(ParamRow(name, v, se, lo, hi, how, num(b[0]), num(b[1]),
                             name in at_bound, name in keys, num(med.get(name))))
    return rows


# ----- flags and diagnostics -------------------------------------------------------------------

FLAG_FIELDS = ("run", "test", "flag", "detail")


def _walk_flags(obj: Any, out: list[dict]) -> None:
    """Every dict found in a list under a key named "flags" (any depth)."""
    if isinstance(obj, Mapping):
        for k, v in obj.items():
            if k == "flags" and isinstance(v, list):
                for f in v:
                    if isinstance(f, Mapping):
                        out.append(dict(f))
                    elif isinstance(f, str):
                        out.append({"run": obj.get("run") or obj.get("id") or "",
                                    "test": obj.get("test") or "", "flag": f, "detail": ""})
            else:
                _walk_flags(v, out)
    elif isinstance(obj, list):
        for v in obj:
            _walk_flags(v, out)


def data_flags(doc: Mapping[str, Any], extraction: Any = None) -> list[dict[str, str]]:
    """Every data-quality flag from fit.json and extraction.json, each once, as
    {run, test, flag, detail} strings."""
    found: list[dict] = [dict(f) for f in (doc.get("flags") or []) if isinstance(f, Mapping)]
    if extraction is not None:
        _walk_flags(extraction, found)
    rows = []
    for f in found:
        row = {k: "" if f.get(k) is None else str(f.get(k)) for k in FLAG_FIELDS}
        extra = {k: v for k, v in f.items() if k not in FLAG_FIELDS}
        if extra and not row["detail"]:
            row["detail"] = ", ".join(f"{k}={v}" for k, v in extra.items())
        rows.append(row)
    # a run's list of flag names repeats flags listed with their detail elsewhere: keep one
    detailed = {(r["run"], r["flag"]) for r in rows if r["detail"]}
    out, seen = [], set()
    for row in rows:
        key = tuple(row.values())
        if key in seen or (not row["detail"] and (row["run"], row["flag"]) in detailed):
            continue
        seen.add(key)
        out.append(row)
    return out


def fit_diagnostics(doc: Mapping[str, Any]) -> list[str]:
    """Warnings about the fits themselves: failures, parameters on bounds, active
    constraints, a best value reached by one start only, MCMC chains too short or with an
    acceptance fraction outside 0.2-0.5."""
    out = [f"FAILED {f}" for f in doc.get("failed") or []]
    for fit in doc.get("fits") or []:
        name = label(fit)
        tag = f"{fit.get('relation')}[{fit.get('form')}]"
        if not fit.get("converged") and not any(str(f).startswith(tag)
                                                for f in doc.get("failed") or []):
            out.append(f"{name}: did not converge ({fit.get('message')})")
        if fit.get("at_bound"):
            out.append(f"{name}: on a bound: {', '.join(fit['at_bound'])}")
        if fit.get("active_constraints"):
            out.append(f"{name}: active constraint(s): {'; '.join(fit['active_constraints'])}")
        n, best = int(fit.get("n_starts") or 0), int(fit.get("starts_at_best") or 0)
        if n > 1 and best <= 1:
            out.append(f"{name}: only {best} of {n} starts reached the best value "
                       "(possible local minimum)")
        mc = fit.get("mcmc")
        if mc:
            short = mcmc_shortfall(mc)
            if short:
                out.append(f"{name}: {short}")
            acc = num(mc.get("acceptance"))
            if math.isfinite(acc) and not 0.2 <= acc <= 0.5:
                out.append(f"{name}: MCMC acceptance fraction {acc:.2f} outside 0.2-0.5")
    return out


def mcmc_shortfall(mc: Mapping[str, Any]) -> str:
    """Why an MCMC summary is not converged, with the cap that would let it converge; empty
    when the chain is longer than 50 autocorrelation times."""
    if mc.get("converged"):
        return ""
    steps = int(mc.get("n_steps") or 0)
    taus = [num(t) for t in (mc.get("tau") or {}).values()]
    taus = [t for t in taus if math.isfinite(t)]
    text = "MCMC chain shorter than 50 autocorrelation times"
    if steps and taus:
        tau = max(taus)
        # the next 1000-step multiple above 50 tau, with 10 % margin for tau still growing
        need = int(math.ceil(55.0 * tau / 1000.0) * 1000)
        text += (f" ({steps} steps, largest tau {tau:.0f}: its intervals are provisional; "
                 f"--mcmc-max-steps {need} would let it reach 50 tau)")
    return text


def mcmc_warnings(doc: Mapping[str, Any]) -> list[str]:
    """The fit_diagnostics lines about MCMC chains that stopped at the cap."""
    return [f"{label(fit)}: {short}" for fit in doc.get("fits") or []
            if fit.get("mcmc") and (short := mcmc_shortfall(fit["mcmc"]))]


def chunks(rows: Iterable, size: int) -> list[list]:
    """Split rows into lists of at most ``size`` (one list, possibly empty, at least)."""
    rows = list(rows)
    return [rows[i:i + size] for i in range(0, len(rows), size)] or [[]]
