"""The kernels' weights in words, as fit, sample and the report say them (no numba: the report
imports it).

With ``kernel: auto`` the discrepancy's kernels are weighed by their likelihood (orthogonal.
kernel_weights) for the interval's width, while the estimate and the sampler keep one kernel's
metric whatever its weight: the words say both, so that "the exp kernel" never stands next to
"exp 0 %" unexplained.
"""

from __future__ import annotations

from bayes_dnlr.numbers import share


def mix_words(weights: dict[str, float], sampled: str) -> str:
    """The weights, the largest first, with what they weigh and what they do not."""
    mix = ", ".join(f"{k} {share(v)}" for k, v in sorted(weights.items(), key=lambda kv: -kv[1]))
    return (f"the kernels' models of the error weighed by their likelihood, {mix}, for the interval's "
            f"width; the estimate and the sampler keep the {sampled} kernel's metric whatever the weights")
