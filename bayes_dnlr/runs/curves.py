"""The model's curves of a run on its data grid, for the report's figures: the posterior median
and 90 % bands (credible and predictive), the least-squares curve, the normalised sensitivities
(eq. 37) and, under the discrepancy likelihood, δ's posterior mean and the whitened residuals.
Computed here (runs/curve_cache.py keeps them), drawn by report/figures.py.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayes_dnlr.inference.discrepancy.axis import Axis
from bayes_dnlr.runs.results import RunResults
from bayes_dnlr.vocabulary import SPECTRUM_EXPONENT, UNIVERSAL_EXPONENT, Z90

N_DRAWS = 200          # posterior draws pushed through the model for the bands


@dataclass
class Curves:
    """Model curves on the data grid (up to the last window sample)."""

    x: np.ndarray
    xlabel: str
    data: np.ndarray
    window: np.ndarray
    strain: np.ndarray
    median: np.ndarray | None = None
    band: tuple[np.ndarray, np.ndarray] | None = None
    predictive: tuple[np.ndarray, np.ndarray] | None = None
    gn_curve: np.ndarray | None = None          # the least-squares fit the posterior is compared with
    white_curve: np.ndarray | None = None       # the white (paper's) least-squares fit
    sensitivities: dict[str, np.ndarray] | None = None


def _model(run: RunResults):
    from bayes_dnlr.inference.test_model import shift_of, temperature_of
    from bayes_dnlr.model import cached_model

    t = run.test
    n = t.model_end
    return cached_model(t.time[:n], t.strain_input[:n], run.cfg.model.modes, run.cfg.model.decades,
                        t.relaxation_start, shift_of(run.cfg), temperature_of(run.cfg, t, n)), n


def _curve(model, p: dict[str, float]) -> np.ndarray:
    """The model's stress at the parameters ``p``: through the basis (linear in E, G, σ_inf), or
    the shifted model's own integration."""
    if model.is_shifted:
        return model.stress(p)
    return _stress(_basis(model, p).values, p)


def _stress(basis_values: np.ndarray, p: dict[str, float]) -> np.ndarray:
    s = p["E"] * basis_values[:, 0] + p["G"] * basis_values[:, 1]
    if "sigma_inf" in p:
        s = s + p["sigma_inf"] * basis_values[:, 2]
    return s


def _basis(model, p: dict[str, float], grad: bool = False):
    """The model's basis at the time constants and spectrum exponent of ``p``."""
    return model.basis(p["tau_max"], p.get("tau_max_R"), grad=grad,
                       alpha=p.get(SPECTRUM_EXPONENT, UNIVERSAL_EXPONENT))


def _model_names(model) -> list[str]:
    """The model's parameters, the optional spectrum exponent included."""
    return [*model.parameter_names(), SPECTRUM_EXPONENT]


def sensitivities(model, params: dict[str, float], names: list[str]) -> dict[str, np.ndarray]:
    """Normalised sensitivities X̃_j = β_j ∂σ/∂β_j (eq. 37), MPa, on the model grid."""
    if model.is_shifted:
        from bayes_dnlr.vocabulary import LOG_COORDINATES

        present = [n for n in names if n in params]
        J = model.jacobian(params, present)
        return {n: J[:, i] if n in LOG_COORDINATES else params[n] * J[:, i]
                for i, n in enumerate(present)}
    b = _basis(model, params, grad=True)
    out = {}
    for n in names:
        if n in ("E", "G", "sigma_inf"):
            out[n] = params[n] * b.values[:, {"E": 0, "G": 1, "sigma_inf": 2}[n]]
        elif n in ("tau_max", "tau_max_R"):
            g = b.grad_tau_max if n == "tau_max" else b.grad_tau_max_R
            if g is not None:
                out[n] = _stress(g, params)   # ∂σ/∂ln tau = tau ∂σ/∂tau
        elif n == SPECTRUM_EXPONENT:
            out[n] = params[n] * _stress(b.grad_alpha, params)
    return out


def run_white_curve(run: RunResults, curves: Curves) -> np.ndarray:
    """The white least-squares fit (fit.json's estimate) on the data grid."""
    return curves.white_curve if curves.white_curve is not None else curves.gn_curve


def model_curves(run: RunResults, n_draws: int = N_DRAWS, seed: int = 0) -> Curves:
    """Data, posterior median and 90 % bands (credible and predictive), the GN curve, sensitivities."""
    t = run.test
    model, n = _model(run)
    relax = t.relaxation_start is not None
    x = t.time[:n] if relax else t.strain_input[:n]
    c = Curves(x=x, xlabel="time (s)" if relax else r"true strain $\varepsilon_{11}$",
               data=np.asarray(t.stress[:n], dtype=float), window=np.asarray(t.window[:n], bool),
               strain=np.asarray(t.strain_input[:n], dtype=float))
    fixed = run.cfg.fixed_values
    point = run.point()
    if all(k in point for k in model.parameter_names()):
        gn = run.gn()
        if gn is not None:
            c.gn_curve = _curve(model, point)
            white = {**fixed, **gn["estimate"]}
            c.white_curve = (c.gn_curve if all(white.get(k) == point.get(k) for k in _model_names(model))
                             else _curve(model, white))
        c.sensitivities = sensitivities(model, point, [k for k in _model_names(model)
                                                       if k in run.model_names])
    if run.draws is not None and all(k in run.draws or k in fixed for k in model.parameter_names()):
        rng = np.random.default_rng(seed)
        total = next(iter(run.draws.values())).size
        pick = rng.choice(total, size=min(n_draws, total), replace=False)
        flat = {k: v.reshape(-1)[pick] for k, v in run.draws.items()}
        sig = flat.get("sigma0")
        s0 = run.sigma0()
        names = [k for k in _model_names(model) if k in flat or k in fixed]
        theta = np.column_stack([flat[k] if k in flat else np.full(pick.size, float(fixed[k]))
                                 for k in names])
        curves = model.stress_batch(theta, names)       # every draw at once, compiled
        c.median = np.median(curves, axis=0)
        lo, hi = np.quantile(curves, [0.05, 0.95], axis=0)
        c.band = (lo, hi)
        # predictive band: model spread, noise and model discrepancy combined as a normal (a smooth
        # band; 200 replicates per point would make it ragged): mean ± 1.645 sqrt(var_model + E[σ0²]
        # (+ E[a²] with the discrepancy))
        s2 = float(np.mean(sig**2)) if sig is not None else (s0**2 if s0 is not None else 0.0)
        if run.uses_discrepancy:
            # the model error enters the prediction too: var(δ) = a² at every point
            amp = flat.get("disc_amplitude")
            fixed_amp = (((run.summary or {}).get("noise") or {}).get("amplitude") or {}).get("value", 0.0)
            s2 += float(np.mean(amp**2)) if amp is not None else float(fixed_amp) ** 2
        half = Z90 * np.sqrt(curves.var(axis=0) + s2)
        mean = curves.mean(axis=0)
        plo, phi = mean - half, mean + half
        c.predictive = (plo, phi)
    return c


@dataclass
class Discrepancy:
    """δ on the compared samples, at the posterior median (or the GLS estimate)."""

    kernel: str
    axis_name: str
    axis: Axis
    residuals: np.ndarray     # data - model on the window, window order
    mean: np.ndarray          # E[δ | residuals], window order
    whitened: np.ndarray      # L⁻¹ residuals, axis order
    hyper: dict[str, float]   # sigma0, amplitude, length used


def _hyper(run: RunResults) -> dict[str, float] | None:
    s = run.summary or {}
    noise = s.get("noise") or {}
    if noise.get("model") != "discrepancy":
        return None
    out = {}
    for key, name in (("sigma0", "sigma0"), ("amplitude", "amplitude"), ("length", "length")):
        block = noise.get(name) or {}
        v = block.get("mean", block.get("value"))
        if v is None:
            return None
        out[key] = float(v)
    return out


def discrepancy_on_window(run: RunResults, model_window: np.ndarray) -> Discrepancy | None:
    """δ's posterior mean and the whitened residuals, given the model on the window's samples."""
    hyper = _hyper(run)
    if hyper is None or run.test is None:
        return None
    from bayes_dnlr.inference.discrepancy import gp
    from bayes_dnlr.inference.discrepancy.axis import test_axis

    t = run.test
    n = t.model_end
    win = np.asarray(t.window[:n], bool)
    noise = run.summary["noise"]
    axis = test_axis(run.cfg.noise.discrepancy, t, win)
    r = np.asarray(t.stress[:n], dtype=float)[win] - model_window
    kind = noise.get("kernel", "exp")
    amp = max(hyper["amplitude"], 0.0)
    mean_sorted = gp.posterior_mean(axis.values, axis.sort(r), hyper["sigma0"], amp, hyper["length"], kind,
                                    axis.origin)
    mean = np.empty_like(mean_sorted)
    if axis.order is None:
        mean = mean_sorted
    else:
        mean[axis.order] = mean_sorted
    white, _ = gp.whiten(axis.values, axis.sort(r), hyper["sigma0"], amp, hyper["length"], kind, axis.origin)
    return Discrepancy(kind, axis.name, axis, r, mean, white, hyper)


def compute_curves(view: RunResults) -> tuple[Curves, Discrepancy | None]:
    """A test's curves (``model_curves``) and, under the discrepancy likelihood, δ given the model
    at its centre (the posterior median, else the least-squares curve)."""
    curves = model_curves(view)
    centre = curves.median if curves.median is not None else curves.gn_curve
    disc = None
    if centre is not None and view.uses_discrepancy:
        disc = discrepancy_on_window(view, centre[curves.window])
    return curves, disc
