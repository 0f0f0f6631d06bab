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


def _fold(r):
    return (r["test"], r["val"], ",".join(r["train"]))


def _paired(runs_a, runs_b, metric="test_f1", unit=_fold):
    """Values of two arms, one per unit of replication, in the same order: the runs both have
    (same split and seed) are matched, and the matched values are averaged per `unit` (a run's
    key; by default its fold, so the seeds of a fold count once). Found in review, 2026-11-27:
    the seeds of a fold share its test, validation and training subjects, so their differences
    are not independent, and pairing every (fold, seed) counted each fold once per seed (eight
    folds' evidence went from p = 0.15 to p = 0.0096 with three seeds)."""
    def key(r):
        return _fold(r) + (r["seed"],)
    a = {key(r): r for r in runs_a}
    b = {key(r): r for r in runs_b}
    units = collections.defaultdict(lambda: ([], []))
    for k in sorted(set(a) & set(b)):
        u = units[unit(a[k])]
        u[0].append(a[k][metric])
        u[1].append(b[k][metric])
    order = sorted(units)
    return [float(np.mean(units[u][0])) for u in order], [float(np.mean(units[u][1])) for u in order]


def _fmt_p(p):
    return "-" if p is None else (f"{p:.3f}" if p >= 0.001 else f"{p:.1e}")


def _options_run(arms, kind, method):
    return {a: rs for a, rs in arms.items() if a.startswith(f"{kind}:{method}:")}


def _best_option_runs(arm_runs, kind, method):
    """The runs standing for (kind, method) when several of its options ran: per fold, the runs
    of the option with the best mean validation F1 on that fold (over its seeds); None if no
    option ran. Found in review, 2026-11-27: the option was chosen by its mean validation F1
    over all folds, and each subject validates one fold (LOSO validates fold i on subject i + 1),
    so the choice for a fold had seen its test subject's labels. A fold's own validation subject
    is never its test subject."""
    cands = _options_run(arm_runs, kind, method)
    if not cands:
        return None
    by_fold = collections.defaultdict(lambda: collections.defaultdict(list))
    for a, rs in cands.items():
        for r in rs:
            by_fold[_fold(r)][a].append(r)
    chosen = []
    for fold, options in sorted(by_fold.items()):
        a = max(sorted(options), key=lambda o: np.mean([r["val_f1"] for r in options[o]]))
        chosen += options[a]
    return chosen


def _option_label(runs):
    """The options a method's runs are of: `2`, or per option its folds when folds chose
    differently (`2 (5), 3 (3)`); `-` for none."""
    if not runs:
        return "-"
    folds = collections.defaultdict(set)
    for r in runs:
        folds[r["arm"].split(":")[2]].add(_fold(r))
    if len(folds) == 1:
        return next(iter(folds))
    return ", ".join(f"{o} ({len(f)})" for o, f in sorted(folds.items()))


def _arm_for(arms, kind, rest):
    """The runs of `kind` standing for `rest`: a method's runs (per fold its option with the best
    validation F1 on that fold: `_best_option_runs`), or the arm `kind:rest` itself (`all`,
    `all:learned`); None if not run."""
    if rest in PAIRS:
        return _best_option_runs(arms, kind, rest)
    return arms.get(f"{kind}:{rest}")


def _vs(runs_a, runs_b):
    """`wilcoxon` of a against b over the folds both have (same split and seed, seeds averaged
    per fold: `_paired`); (None, 0, 0.0) when either arm did not run."""
    if not runs_a or not runs_b:
        return None, 0, 0.0
    return wilcoxon(*_paired(runs_a, runs_b))


def _test_f1(runs):
    return _pct([r["test_f1"] for r in runs])


UNIT_FOLD = ("p: two-sided Wilcoxon signed-rank, paired per fold: the unit of replication is the "
             "test subject (the seeds of a fold averaged first), n = the folds both arms ran.")

# The rows of the one-at-a-time table: the six method pairs, then the `all` arms side by side.
_ALL_ROWS = {"all": "all 810 uniform", "all:learned": "all 810 learned"}


def one_at_a_time(doc):
    """Markdown: per model, each arm's test macro F1 (mean ± std over folds x seeds) and per pair
    the Wilcoxon test PPDA vs STDA and each vs baseline, paired per fold; returns (markdown,
    figure data)."""
    lines = []
    fig = {}
    for model, runs in sorted(_by(doc["runs"], "model").items()):
        model = model[0]
        arms = {a[0]: rs for a, rs in _by(runs, "arm").items()}
        base = arms.get("baseline", [])
        folds = sorted({r["test"] for r in runs})
        seeds = sorted({r["seed"] for r in runs})
        lines += [f"### {model}", "",
                  f"Test macro F1 (%), mean ± std over every run ({len(folds)} test subjects x {len(seeds)} "
                  f"seed(s)); baseline {_test_f1(base)}. {UNIT_FOLD}", "",
                  "| method pair | STDA | PPDA | PPDA - STDA (pp) | p PPDA vs STDA | p STDA vs baseline | p PPDA vs baseline | option (STDA / PPDA) |",
                  "|---|---|---|---|---|---|---|---|"]
        fig[model] = {"baseline": [r["test_f1"] for r in base], "pairs": []}
        rows = [(m, f"{n[0]} / {n[1]}", f"{n[0]}\n{n[1]}") for m, n in PAIRS.items()]
        rows += [(rest, f"{name} (STDA / PPDA)", f"{name}\n(STDA / PPDA)") for rest, name in _ALL_ROWS.items()]
        for rest, name, fig_name in rows:
            s_runs = _arm_for(arms, "stda", rest) or []
            p_runs = _arm_for(arms, "ppda", rest) or []
            if not s_runs and not p_runs:
                continue
            p_ps, n, diff = _vs(p_runs, s_runs)
            opt = f"{_option_label(s_runs)} / {_option_label(p_runs)}" if rest in PAIRS else "- / -"
            lines.append(f"| {name} | {_test_f1(s_runs)} | {_test_f1(p_runs)} | "
                         f"{100 * diff:+.1f} (n={n}) | {_fmt_p(p_ps)} | {_fmt_p(_vs(s_runs, base)[0])} | "
                         f"{_fmt_p(_vs(p_runs, base)[0])} | {opt} |")
            fig[model]["pairs"].append((fig_name, [r["test_f1"] for r in s_runs],
                                        [r["test_f1"] for r in p_runs]))
        lines.append("")
        # Arms of no pair (sim-only, ...) in a table of their own. Found in review, 2026-11-27:
        # they were rows of the pair table with their F1 in the PPDA column and their p under
        # "p PPDA vs baseline", STDA arms (`stda:all`) included.
        paired = {f"{k}:{rest}" for k in ("stda", "ppda") for rest in _ALL_ROWS}
        extra = sorted(a for a in arms if a != "baseline" and a not in paired
                       and a.split(":")[1] not in PAIRS and not a.startswith("ppda-residual:"))
        if extra:
            lines += ["Other arms:", "", "| arm | test F1 | - baseline (pp) | p vs baseline |", "|---|---|---|---|"]
            for a in extra:
                p, n, d = _vs(arms[a], base)
                lines.append(f"| {parse_arm(a).label} | {_test_f1(arms[a])} | {100 * d:+.1f} (n={n}) | {_fmt_p(p)} |")
            lines.append("")
        lines += _residual_rows(arms, base)
        options = sorted(a for a in arms if a.count(":") == 2 and a.split(":")[1] in PAIRS)
        kinds = ("stda", "ppda", "ppda-residual")
        if any(len([o for o in options if o.startswith(f"{k}:{m}:")]) > 1 for k in kinds for m in PAIRS):
            lines += ["Every option (the tables above take, per method and fold, the option with the best "
                      "validation F1 on that fold, never its test score; the option column counts the folds "
                      "of each option chosen):", "", "| arm | validation F1 | test F1 |", "|---|---|---|"]
            for a in options:
                lines.append(f"| {a} | {_pct([r['val_f1'] for r in arms[a]])} | {_test_f1(arms[a])} |")
            lines.append("")
    return "\n".join(lines), fig


def _residual_rows(arms, base):
    """Markdown rows for the residual PPDA arms run: each (per method and fold the option with the
    best validation F1 on that fold; the `all` arms as they are) against PPDA proper, STDA and the
    baseline, paired per fold; [] when none ran."""
    rows = []
    for rest in list(PAIRS) + list(_ALL_ROWS):
        r_runs = _arm_for(arms, "ppda-residual", rest)
        if not r_runs:
            continue
        cells = []
        for kind in ("ppda", "stda"):
            other = _arm_for(arms, kind, rest)
            p, n, d = _vs(r_runs, other) if other else (None, 0, 0.0)
            cells.append(f"{100 * d:+.1f} (n={n}) | {_fmt_p(p)}" if other else "- | -")
        name = PAIRS[rest][1] if rest in PAIRS else parse_arm(f"ppda-residual:{rest}").label
        option = _option_label(r_runs) if rest in PAIRS else "-"
        rows.append(f"| {name} | {_test_f1(r_runs)} | {cells[0]} | {cells[1]} | "
                    f"{_fmt_p(_vs(r_runs, base)[0])} | {option} |")
    if not rows:
        return []
    return ["Residual PPDA (the sub-policy's change added to the real window), paired per fold as "
            "above (the unit is the test subject):", "",
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
        # Found in review, 2026-11-27: the splits of all sizes were tested as independent pairs,
        # but splits share their test subject (and their validation subject, and the smaller
        # training sets lie inside the larger ones): eight splits over two test subjects read as
        # eight pairs. Each test subject's splits are averaged first, over every size.
        tests = sorted({r["test"] for r in runs})
        lines += [f"Two-sided Wilcoxon signed-rank over all sizes, paired per test subject: the unit of "
                  f"replication is the test subject (its splits of every size, matched by split and seed, "
                  f"averaged first), n = the test subjects both arms ran ({len(tests)} here: "
                  f"{', '.join(tests)}; an exact two-sided p is at least 2 / 2^n, none with fewer than 2):", ""]
        for a, b in (("ppda:all", "stda:all"), ("ppda:all:learned", "ppda:all"), ("ppda:all", "baseline"),
                     ("stda:all", "baseline"), ("ppda:all:learned", "baseline"),
                     ("ppda-residual:all", "ppda:all"), ("ppda-residual:all", "stda:all"),
                     ("ppda-residual:all", "baseline"), ("ppda-residual:all:learned", "ppda:all:learned"),
                     ("ppda-residual:all:learned", "ppda-residual:all"), ("ppda-residual:all:learned", "baseline")):
            ra = [r for r in runs if r["arm"] == a]
            rb = [r for r in runs if r["arm"] == b]
            if ra and rb:
                p, n, d = wilcoxon(*_paired(ra, rb, unit=lambda r: r["test"]))
                lines.append(f"- {parse_arm(a).label} vs {parse_arm(b).label}: {100 * d:+.1f} pp, p = {_fmt_p(p)} "
                             f"(n={n} test subjects)")
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
                  "", f"Fidelity gap (sim-only minus real, paired per fold, the seeds of a fold averaged "
                  f"first): {100 * d:+.1f} pp macro F1, p = {_fmt_p(p)} (n={n} test subjects).", ""]
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
          f"{screen}; protocol {s['protocol']} (docs/har.md, \"Protocol versions\").", "", table, "#### Speed", "", speed(doc), ""]
    md += provenance(doc)
    text = "\n".join(md)
    with open(os.path.join(out_dir, f"{exp}.md"), "w", encoding="utf-8") as f:
        f.write(text)
    if fig:
        plot(doc, fig, os.path.join(out_dir, f"{exp}.png"))
    return text
