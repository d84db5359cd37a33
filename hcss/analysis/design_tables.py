"""Tables of the tests that respect the repeated-measures design."""

from __future__ import annotations

import math

import pandas as pd

from hcss.analysis.builders import SPLIT_LABELS
from hcss.analysis.clustered import ClusteredModel
from hcss.analysis.measures import measure_label
from hcss.analysis.paired import RepeatedComparison
from hcss.analysis.tables import (
    Table,
    effect_cell,
    effect_record,
    format_number,
    format_p,
)
from hcss.tablespec.analysis import analysis_table


def friedman_table(comparisons: list[RepeatedComparison]) -> Table:
    """Friedman χ²(df, N = participants), p and Kendall's W per measure and split."""
    rows, records = [], []
    for comparison in comparisons:
        result = comparison.friedman
        if result is None:
            continue
        statistic = (
            f"χ²({result.df:g}, N = {result.n}) = {format_number(result.statistic)}"
            if result.statistic == result.statistic
            else "–"
        )
        rows.append(
            (
                measure_label(comparison.measure),
                SPLIT_LABELS[comparison.split],
                statistic,
                format_p(result.p),
                effect_cell(result),
                result.method,
                comparison.note,
            )
        )
        records.append(
            {
                "measure": comparison.measure,
                "split": comparison.split,
                "n": result.n,
                "chi2": result.statistic,
                "df": result.df,
                "p": result.p,
                **effect_record(result, "kendall_w"),
                "method": result.method,
                "note": comparison.note,
            }
        )
    return Table(
        "friedman",
        "Friedman tests across M1, M2, M3 (participants with all three), with Kendall's W "
        "and a percentile bootstrap interval (2,000 resamples of participants, seeded)",
        ("Measure", "Split", "χ²(df, N)", "p", "W [95% CI]", "Test", "Note"),
        tuple(rows),
        pd.DataFrame(records),
    )


def paired_wilcoxon_table(comparisons: list[RepeatedComparison]) -> Table:
    """Pairwise signed-rank tests: V, n, p, Holm p and r per pair."""
    rows, records = [], []
    for comparison in comparisons:
        for pair in comparison.pairs:
            result = pair.result
            rows.append(
                (
                    measure_label(comparison.measure),
                    SPLIT_LABELS[comparison.split],
                    f"{pair.group_a} − {pair.group_b}",
                    str(result.n),
                    format_number(result.statistic, 1),
                    format_p(result.p),
                    format_p(pair.p_holm),
                    effect_cell(result),
                    result.method or result.note,
                )
            )
            records.append(
                {
                    "measure": comparison.measure,
                    "split": comparison.split,
                    "group_a": pair.group_a,
                    "group_b": pair.group_b,
                    "n": result.n,
                    "V": result.statistic,
                    "p": result.p,
                    "p_holm": pair.p_holm,
                    **effect_record(result, "rank_biserial_r"),
                    "method": result.method,
                    "note": result.note,
                }
            )
    return Table(
        "wilcoxon_paired",
        "Paired Wilcoxon signed-rank tests, Holm-adjusted within measure and split; "
        "matched-pairs rank-biserial r with its Fisher-z interval",
        ("Measure", "Split", "Pair", "n", "V", "p", "p (Holm)", "r_rb [95% CI]", "Test"),
        tuple(rows),
        pd.DataFrame(records),
    )


def model_table(name: str, model: ClusteredModel) -> Table:
    """Ratios exp(β) with 95% intervals and Wald z p; variance components as rows beneath.

    The caption names the method, the order covariates and the cluster
    counts; a model that was not fitted is one row saying why.
    """
    robust = any(not math.isnan(term.robust_p) for term in model.terms)
    rows = [
        (
            term.term,
            format_number(term.ratio, 3),
            f"[{format_number(term.lower, 3)}, {format_number(term.upper, 3)}]",
            format_p(term.p),
        )
        + (
            (
                f"[{format_number(term.robust_lower, 3)}, {format_number(term.robust_upper, 3)}]",
                f"{format_p(term.robust_p)} ({term.robust_df:.1f} df)",
                format_number(term.detectable, 2),
            )
            if robust
            else ()
        )
        for term in model.terms
    ]
    blank = ("", "", "") if robust else ()
    rows += [
        (f"Variance: {component.name}", f"{component.variance:.3g}", "", "", *blank)
        for component in model.variance
        if model.terms
    ]
    if not rows:
        rows = [("not fitted", "–", "–", model.note or "–")]
    if not model.terms:  # no fit: no order term to describe, only the reason
        caption = (
            f"{model.outcome.capitalize()} by model × difficulty: not fitted ({model.note}); "
            f"{model.n_decisions} decisions of {model.n_participants} participants"
        )
    else:
        order = (
            f" + order ({', '.join(COVARIATE_LABELS[name] for name in model.covariates)})"
            if model.covariates
            else " (order did not vary: no order term)"
        )
        caption = (
            f"{model.outcome.capitalize()} by model × difficulty{order}: {model.method}; "
            f"p from {model.p_method}; "
            f"{model.n_decisions} decisions of {model.n_participants} participants"
            + (f" ({model.note})" if model.note else "")
            + (ROBUST_NOTE if robust else "")
            + (GEE_QUESTION if name == "gee_success" else "")
        )
    spec = analysis_table(name)
    ratio = spec.column(model.ratio_name.replace(" ", "_")).name  # KeyError: not this table's
    records = [
        {"term": t.term, ratio: t.ratio, "lower": t.lower}
        | {"upper": t.upper, "p": t.p, "p_method": model.p_method, "note": model.note}
        | (
            {
                "robust_lower": t.robust_lower,
                "robust_upper": t.robust_upper,
                "robust_p": t.robust_p,
                "robust_df": t.robust_df,
                "detectable_ratio": t.detectable,
            }
            if robust
            else {}
        )
        for t in model.terms
    ] + [
        {"term": f"variance: {component.name}", "variance": component.variance}
        for component in model.variance
    ]
    if not model.terms:  # the reason, under the same header, so a reader of the CSV sees it
        records = [
            {"term": "not fitted", "p": None, "p_method": model.p_method, "note": model.note}
        ]
    frame = pd.DataFrame(records, columns=list(spec.names))
    return Table(
        name,
        caption,
        ("Term (vs M1, easy)", model.ratio_name.capitalize(), "95% CI", f"p ({model.p_method})")
        + (
            (
                "CR2 95% CI",
                "CR2 p (Satterthwaite df)",
                "Detectable ratio (80% power)",
            )
            if robust
            else ()
        ),
        tuple(rows),
        frame,
    )


#: What the mixed model assumes, and what the robust columns add (the caption's last words).
ROBUST_NOTE = (
    ". The model-based errors assume a random intercept only: every participant shifted "
    "alike, reacting to M2, M3 and difficulty alike. The CR2 columns keep the estimates but "
    "take the errors from each participant's residuals (cluster-robust CR2, Satterthwaite "
    "df, Bell–McCaffrey; clubSandwich's coef_test), valid without that assumption; few df "
    "mean few participants carry the term. Detectable ratio: the smallest time ratio (or "
    "its inverse) the CR2 test finds with 80% power at α = .05, exp((t.975 + t.80)·SE)"
)

#: Which question the GEE answers, beside analysis.R's glmer (the GEE caption's last words).
GEE_QUESTION = (
    ". Population-averaged: how the odds of success differ between models over the "
    "participants as a whole. analysis.R's glmer answers the subject-specific question (for "
    "one participant, holding their intercept), whose odds ratios are further from 1 and "
    "whose Laplace p uses no small-sample correction, so the two p can differ at few "
    "participants without either being wrong"
)

COVARIATE_LABELS = {
    "position": "trial position 1–3",
    "first_section": "first section",
}
