"""Tables (markdown), paired tests and plots from an experiment's JSON (`experiments.py`)."""
import collections
import os

import numpy as np

from . import experiments
from .experiments import PAIRS, parse_arm


def _pct(values):
    v = 100.0 * np.asarray(values, float)
    if len(v) == 0:
        return "-"
    return f"{v.mean():.1f} ± {v.std(ddof=1) if len(v) > 1 else 0.0:.1f}"


def wilcoxon(a, b):
    """Two-sided Wilcoxon signed-rank test of paired samples (SciPy); (p, n pairs, mean a - b).
    Pairs that tie exactly are left out (Wilcoxon's own convention) and p is exact over the rest:
    SciPy given a zero difference silently switches to its normal approximation (seven wins and
    a tie read 0.018, not 2 / 2^7 = 0.0156). p is None with fewer than 2 non-zero differences."""
    from scipy.stats import wilcoxon as w
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = a - b
    nonzero = d[d != 0]
    if len(nonzero) < 2:
        return None, len(d), float(d.mean()) if len(d) else 0.0
    return float(w(nonzero, method="exact").pvalue), len(d), float(d.mean())


def _by(runs, *keys):
    out = collections.defaultdict(list)
    for r in runs:
        out[tuple(r[k] for k in keys)].append(r)
    return out


def _paired(runs_a, runs_b, metric="test_f1"):
    """Values of two arms on the splits and seeds both have, in the same order."""
    def key(r):
        return (r["test"], r["val"], ",".join(r["train"]), r["seed"])
    a = {key(r): r[metric] for r in runs_a}
    b = {key(r): r[metric] for r in runs_b}
    common = sorted(set(a) & set(b))
    return [a[k] for k in common], [b[k] for k in common]


def _fmt_p(p):
    return "-" if p is None else (f"{p:.3f}" if p >= 0.001 else f"{p:.1e}")


def _best_option(arm_runs, kind, method):
    """Among the options of (kind, method) that were run, the one with the best mean validation F1
    (the selection never looks at the test subject)."""
    cands = {a: rs for a, rs in arm_runs.items() if a.startswith(f"{kind}:{method}:")}
    if not cands:
        return None
    return max(cands, key=lambda a: np.mean([r["val_f1"] for r in cands[a]]))


def _arm_for(arms, kind, rest):
    """The arm of `kind` standing for `rest`: a method's option with the best validation F1
    (`_best_option`), or the arm `kind:rest` itself (`all`, `all:learned`); None if not run."""
    if rest in PAIRS:
        return _best_option(arms, kind, rest)
    return f"{kind}:{rest}" if f"{kind}:{rest}" in arms else None


def _vs(runs_a, runs_b):
    """`wilcoxon` of a against b over the runs both have (same split and seed: `_paired`);
    (None, 0, 0.0) when either arm did not run."""
    if not runs_a or not runs_b:
        return None, 0, 0.0
    return wilcoxon(*_paired(runs_a, runs_b))


def _test_f1(runs):
    return _pct([r["test_f1"] for r in runs])


def one_at_a_time(doc):
    """Markdown: per model, each arm's test macro F1 (mean ± std over folds x seeds) and per pair
    the Wilcoxon test PPDA vs STDA and each vs baseline; returns (markdown, figure data)."""
    lines = []
    fig = {}
    for model, runs in sorted(_by(doc["runs"], "model").items()):
        model = model[0]
        arms = {a[0]: rs for a, rs in _by(runs, "arm").items()}
        base = arms.get("baseline", [])
        folds = sorted({r["test"] for r in runs})
        seeds = sorted({r["seed"] for r in runs})
        lines += [f"### {model}", "",
                  f"Test macro F1 (%), mean ± std over {len(folds)} test subjects x {len(seeds)} seed(s); "
                  f"baseline {_test_f1(base)}. p: two-sided Wilcoxon signed-rank "
                  "over the paired (test subject, seed) runs.", "",
                  "| method pair | STDA | PPDA | PPDA - STDA (pp) | p PPDA vs STDA | p STDA vs baseline | p PPDA vs baseline | option (STDA / PPDA) |",
                  "|---|---|---|---|---|---|---|---|"]
        fig[model] = {"baseline": [r["test_f1"] for r in base], "pairs": []}
        for method, (stda_name, ppda_name, *_rest) in PAIRS.items():
            sa, pa = _arm_for(arms, "stda", method), _arm_for(arms, "ppda", method)
            if sa is None and pa is None:
                continue
            s_runs, p_runs = arms.get(sa, []), arms.get(pa, [])
            p_ps, n, diff = wilcoxon(*_paired(p_runs, s_runs))
            opt = f"{sa.split(':')[2] if sa else '-'} / {pa.split(':')[2] if pa else '-'}"
            lines.append(f"| {stda_name} / {ppda_name} | {_test_f1(s_runs)} | {_test_f1(p_runs)} | "
                         f"{100 * diff:+.1f} (n={n}) | {_fmt_p(p_ps)} | {_fmt_p(_vs(s_runs, base)[0])} | "
                         f"{_fmt_p(_vs(p_runs, base)[0])} | {opt} |")
            fig[model]["pairs"].append((f"{stda_name}\n{ppda_name}", [r["test_f1"] for r in s_runs],
                                        [r["test_f1"] for r in p_runs]))
        extra = [a for a in arms if a != "baseline" and a.split(":")[1] not in PAIRS
                 and not a.startswith("ppda-residual:")]
        for a in sorted(extra):
            lines.append(f"| {parse_arm(a).label} | | {_test_f1(arms[a])} | | | | {_fmt_p(_vs(arms[a], base)[0])} | |")
        lines.append("")
        lines += _residual_rows(arms, base)
        options = sorted(a for a in arms if a.count(":") == 2 and a.split(":")[1] in PAIRS)
        kinds = ("stda", "ppda", "ppda-residual")
        if any(len([o for o in options if o.startswith(f"{k}:{m}:")]) > 1 for k in kinds for m in PAIRS):
            lines += ["Every option (the table above takes, per method, the option with the best mean "
                      "validation F1):", "", "| arm | validation F1 | test F1 |", "|---|---|---|"]
            for a in options:
                lines.append(f"| {a} | {_pct([r['val_f1'] for r in arms[a]])} | {_test_f1(arms[a])} |")
            lines.append("")
    return "\n".join(lines), fig


def _residual_rows(arms, base):
    """Markdown rows for the residual PPDA arms run: each (per method the option with the best
    validation F1; the `all` arms as they are) against PPDA proper, STDA and the baseline,
    paired; [] when none ran."""
    rows = []
    for rest in list(PAIRS) + ["all", "all:learned"]:
        ra = _arm_for(arms, "ppda-residual", rest)
        if ra is None:
            continue
        r_runs = arms[ra]
        cells = []
        for kind in ("ppda", "stda"):
            other = _arm_for(arms, kind, rest)
            p, n, d = _vs(r_runs, arms[other]) if other else (None, 0, 0.0)
            cells.append(f"{100 * d:+.1f} (n={n}) | {_fmt_p(p)}" if other else "- | -")
        name = PAIRS[rest][1] if rest in PAIRS else parse_arm(ra).label
        option = ra.split(":")[2] if rest in PAIRS else "-"
        rows.append(f"| {name} | {_test_f1(r_runs)} | {cells[0]} | {cells[1]} | "
                    f"{_fmt_p(_vs(r_runs, base)[0])} | {option} |")
    if not rows:
        return []
    return ["Residual PPDA (the sub-policy's change added to the real window), paired over the same "
            "(test subject, seed) runs:", "",
            "| method | PPDA residual | - PPDA (pp) | p | - STDA (pp) | p | p vs baseline | option |",
            "|---|---|---|---|---|---|---|---|"] + rows + [""]


def fewer_subjects(doc):
    lines, fig = [], {}
    for model, runs in sorted(_by(doc["runs"], "model").items()):
        model = model[0]
        arms = sorted({r["arm"] for r in runs}, key=lambda a: (a != "baseline", a))
        sizes = sorted({r["n_train"] for r in runs})
        lines += [f"### {model}", "", "Test macro F1 (%), mean ± std over the training-subject subsets "
                  "(splits per size in brackets).", "",
                  "| training subjects | " + " | ".join(parse_arm(a).label for a in arms) + " |",
                  "|---|" + "---|" * len(arms)]
        fig[model] = {a: [] for a in arms}
        for n in sizes:
            cells = []
            for a in arms:
                v = [r["test_f1"] for r in runs if r["arm"] == a and r["n_train"] == n]
                cells.append(f"{_pct(v)} [{len(v)}]")
                if v:
                    fig[model][a].append((n, float(np.mean(v)), float(np.std(v))))
            lines.append(f"| {n} | " + " | ".join(cells) + " |")
        lines.append("")
        lines += ["Paired (same split) Wilcoxon p-values over all sizes:", ""]
        for a, b in (("ppda:all", "stda:all"), ("ppda:all:learned", "ppda:all"), ("ppda:all", "baseline"),
                     ("stda:all", "baseline"), ("ppda:all:learned", "baseline"),
                     ("ppda-residual:all", "ppda:all"), ("ppda-residual:all", "stda:all"),
                     ("ppda-residual:all", "baseline"), ("ppda-residual:all:learned", "ppda:all:learned"),
                     ("ppda-residual:all:learned", "ppda-residual:all"), ("ppda-residual:all:learned", "baseline")):
            ra = [r for r in runs if r["arm"] == a]
            rb = [r for r in runs if r["arm"] == b]
            if ra and rb:
                p, n, d = wilcoxon(*_paired(ra, rb))
                lines.append(f"- {parse_arm(a).label} vs {parse_arm(b).label}: {100 * d:+.1f} pp, p = {_fmt_p(p)} (n={n})")
        lines.append("")
    return "\n".join(lines), fig


def sim_only(doc):
    lines = []
    for model, runs in sorted(_by(doc["runs"], "model").items()):
        model = model[0]
        real = [r for r in runs if r["arm"] == "baseline"]
        sim = [r for r in runs if r["arm"] == "sim:identity"]
        a, b = _paired(sim, real)
        p, n, d = wilcoxon(a, b)
        lines += [f"### {model}", "", "| trained on | test macro F1 (%) | test accuracy (%) | validation F1 (%) |",
                  "|---|---|---|---|",
                  f"| real windows | {_pct([r['test_f1'] for r in real])} | {_pct([r['test_acc'] for r in real])} | {_pct([r['val_f1'] for r in real])} |",
                  f"| re-simulated windows only | {_pct([r['test_f1'] for r in sim])} | {_pct([r['test_acc'] for r in sim])} | {_pct([r['val_f1'] for r in sim])} |",
                  "", f"Fidelity gap (sim-only minus real, paired): {100 * d:+.1f} pp macro F1, p = {_fmt_p(p)} (n={n}).", ""]
    return "\n".join(lines), None


def speed(doc):
    lines = ["| arm kind | runs | mean step (ms) | imukit share of a step (%), mean [max] | mean run (s) | epochs run |",
             "|---|---|---|---|---|---|"]
    by_kind = collections.defaultdict(list)
    for r in doc["runs"]:
        a = parse_arm(r["arm"])
        kind = (a.kind + (" residual" if a.residual else "") + (" learned" if a.learned else "")
                + (" sim-only" if a.resimulate_identity else ""))
        by_kind[(r["model"], kind)].append(r)
    for (model, kind), rs in sorted(by_kind.items()):
        share = np.array([r["imukit_share"] for r in rs])
        lines.append(f"| {model} {kind} | {len(rs)} | {1e3 * np.mean([r['step_seconds_mean'] for r in rs]):.0f} | "
                     f"{100 * share.mean():.2f} [{100 * share.max():.2f}] | {np.mean([r['seconds'] for r in rs]):.0f} | "
                     f"{np.mean([r['epochs_run'] for r in rs]):.1f} |")
    cpu = sum(r["seconds"] for r in doc["runs"])
    lines += ["", f"{len(doc['runs'])} runs, {cpu / 3600:.2f} CPU hours of training (sum of runs), "
              f"{doc.get('wall_seconds', 0.0) / 3600:.2f} hours wall clock."]
    return "\n".join(lines)


def plot(doc, fig, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    exp = doc["experiment"]
    models = sorted(fig)
    f, axes = plt.subplots(1, len(models), figsize=(7 * len(models), 4.2), squeeze=False)
    for ax, model in zip(axes[0], models):
        d = fig[model]
        if exp == "one_at_a_time":
            pairs = d["pairs"]
            x = np.arange(len(pairs))
            for off, idx, color, name in ((-0.2, 1, "tab:blue", "STDA"), (0.2, 2, "tab:orange", "PPDA")):
                means = [100 * np.mean(p[idx]) if p[idx] else np.nan for p in pairs]
                stds = [100 * np.std(p[idx]) if p[idx] else 0 for p in pairs]
                ax.bar(x + off, means, 0.4, yerr=stds, color=color, label=name, capsize=3)
            if d["baseline"]:
                ax.axhline(100 * np.mean(d["baseline"]), color="k", ls="--", label="baseline")
            ax.set_xticks(x)
            ax.set_xticklabels([p[0] for p in pairs], fontsize=7)
        else:
            for arm, pts in d.items():
                if pts:
                    n, m, s = zip(*pts)
                    ax.errorbar(n, 100 * np.array(m), yerr=100 * np.array(s), marker="o", capsize=3,
                                label=parse_arm(arm).label)
            base = d.get("baseline")
            if base:
                ax.axhline(100 * max(m for _, m, _ in base), color="k", ls="--", lw=0.8, label="best baseline")
            ax.set_xlabel("training subjects")
        ax.set_ylabel("test macro F1 (%)")
        ax.set_title(f"UTD-MHAD, {model}")
        ax.legend(fontsize=7)
    f.tight_layout()
    f.savefig(path, dpi=110)
    plt.close(f)


def provenance(doc):
    """For a merged document: which file holds which folds, and where their data differ."""
    parts = (doc.get("data") or {}).get("parts")
    if not parts:
        return []
    lines = ["#### Merged from", "", "| file | runs | test subjects | recordings without a scene |", "|---|---|---|---|"]
    for p in parts:
        lines.append(f"| {p['file']} | {p['runs']} | {', '.join(p['tests'])} | "
                     f"{len((p.get('data') or {}).get('recordings_without_scene') or [])} |")
    differ = doc["data"].get("fingerprints_differ") or []
    lines.append("")
    if differ:
        sets = [set((p.get("data") or {}).get("recordings_without_scene") or []) for p in parts]
        changed = sorted(set.union(*sets) - set.intersection(*sets))
        lines.append(f"The files' recordings differ for subject(s) {', '.join(differ)}: "
                     f"{len(changed)} recording(s) have a scene in one file and not in another "
                     f"({', '.join(changed) or 'none: lengths, channels or rates differ'}).")
    scenes = doc["data"].get("scenes_differ") or []
    if scenes:
        lines.append(f"The files' fitted scenes differ for subject(s) {', '.join(scenes)} (their "
                     "files' contents: fitted again, or by another version).")
    if not differ and not scenes:
        lines.append("Every file was made from the same recordings and scenes (per-subject digests "
                     "agree).")
    return lines + [""]


def write(doc, out_dir):
    """Writes <experiment>.md (and .png) beside the JSON; returns the markdown."""
    exp = doc["experiment"]
    table, fig = {"one_at_a_time": one_at_a_time, "fewer_subjects": fewer_subjects,
                  "sim_only": sim_only}[exp](doc)
    s = experiments.settings_of(doc)
    screen = f", PPDA outputs above {s['output_screen']:g}x the real peak kept real" if s["output_screen"] else ""
    steps = f" of {s['steps_per_epoch']} mini-batches" if s["steps_per_epoch"] else ""
    md = [f"## {exp.replace('_', ' ')}", "",
          f"window {s['window']} / stride {s['stride']} samples, batch {s['batch_size']}, up to {s['epochs']} epochs{steps} "
          f"(early stop after {s['patience']} without a better validation F1), policy grid `{s['policy']}`"
          f"{', tiny models' if s['tiny'] else ''}"
          f"{screen}.", "", table, "#### Speed", "", speed(doc), ""]
    md += provenance(doc)
    text = "\n".join(md)
    with open(os.path.join(out_dir, f"{exp}.md"), "w", encoding="utf-8") as f:
        f.write(text)
    if fig:
        plot(doc, fig, os.path.join(out_dir, f"{exp}.png"))
    return text
