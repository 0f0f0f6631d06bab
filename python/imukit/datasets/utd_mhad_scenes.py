"""Every UTD-MHAD trial as a fitted scene (docs/identification.md, "UTD-MHAD"; the folder layout
is in docs/formats.md, "Fitted scenes"), plus a fidelity table.

Per trial: the Kinect skeleton becomes a Body + Motion (imukit.motion_from_keypoints, with the
subject's segment lengths: imukit.average_bodies over the subject's trials), the IMU is fitted to
it (imukit.identify: placement, biases, time offset and time scale, the twist of the sensor's
segment), and the fit is written as a scene folder that imukit.read_scene and imukit.Augmenter
load; the written scene is simulated again and compared with the real IMU.

    python3 -m imukit.datasets.utd_mhad_scenes ROOT OUT [--threads 2] [--subjects 1,2] [--limit N]

or from Python: fit_dataset(root, out, threads=2). The C++ work releases the GIL, so the trials
run in parallel on a thread pool.
"""
import argparse
import collections
import concurrent.futures
import json
import os
import sys
import time

import numpy as np

import imukit
from imukit.datasets import utd_mhad
from imukit.har.arguments import number

TOPOLOGY = "kinect_v1_20"
# Where the sensor sat and what to start from: the site's segment and the nearest preset (its
# position; the rotation is found from the data).
SITES = {"right_wrist": ("right_forearm", "right_wrist_watch"),
         "right_thigh": ("right_thigh", "right_front_pocket_phone")}
# The fit's settings (docs/identification.md, "UTD-MHAD", says why each).
FIT = dict(correction="twist", knot_spacing_s=0.3, estimate=("clock_rate",), max_clock_rate=0.05,
           max_time_offset_s=0.5, accel_bias_prior_mps2=0.5, gyro_bias_prior_radps=0.05,
           function_tolerance=1e-6)
IMU_PERIOD_NS = 20_000_000  # 50 Hz


def _series(trial):
    t = np.arange(len(trial.accel), dtype=np.int64) * IMU_PERIOD_NS
    return imukit.Series(t, trial.accel, trial.gyro)


def _keypoint_motion(trial, body=None):
    # The README: the skeleton spans the IMU's interval; frames are spread evenly over it.
    times = np.linspace(0.0, trial.duration_s, len(trial.keypoints))
    return imukit.motion_from_keypoints(trial.keypoints, TOPOLOGY, times=times, body=body)


def subject_bodies(root, trials, threads=2):
    """{subject: Body}: each subject's segment lengths, the joint-wise median over their trials
    (imukit.average_bodies); trials whose keypoints cannot be converted are left out."""
    def one(tid):
        try:
            return tid.subject, _keypoint_motion(utd_mhad.load_trial(root, tid))[0]
        except (imukit.Error, ValueError):  # fit_trial reports it
            return tid.subject, None
    per_subject = collections.defaultdict(list)
    with concurrent.futures.ThreadPoolExecutor(max_workers=threads) as pool:
        for subject, body in pool.map(one, trials):
            if body is not None:
                per_subject[subject].append(body)
    return {s: imukit.average_bodies(b) for s, b in per_subject.items()}


def _fidelity(f):
    return {"accel": {"rmse": [float(v) for v in f["accel"]["rmse"]],
                      "correlation": [float(v) for v in f["accel"]["correlation"]]},
            "gyro": {"rmse": [float(v) for v in f["gyro"]["rmse"]],
                     "correlation": [float(v) for v in f["gyro"]["correlation"]]},
            "samples": int(f["samples"])}


def _identify(body, motion, imu, info, site, correction):
    joint, preset = SITES[site]
    options = dict(FIT, correction=correction, motion_start_ns=int(round(info["start_s"] * 1e9)),
                   invalid_motion=info["invalid_motion_ns"])
    try:
        return imukit.identify(body, motion, imu, joint, init=preset, **options), None
    except imukit.Error as e:
        if "time offset is unobservable" not in str(e):
            raise
        # The |w| cross-correlation found no clear peak: the streams start together (README),
        # so start from offset 0 and let the fine fit move it within its window.
        return (imukit.identify(body, motion, imu, joint, init=preset, time_offset_s=0.0, **options),
                f"coarse timing failed ({e}); started from offset 0")


def _runs(indices):
    """Sorted sample indices as [first, last] runs of consecutive ones."""
    runs = []
    for i in (int(v) for v in indices):
        if runs and i == runs[-1][1] + 1:
            runs[-1][1] = i
        else:
            runs.append([i, i])
    return runs


def fit_trial(root, trial_id, out_dir, body=None, rigid=True):
    """Fits one trial and writes out_dir/<stem>/ (scene.json, motion.csv, placement.json).
    Returns its record for the fidelity table (status "ok" or "failed" with the reason)."""
    rec = {"trial": trial_id.stem, "action": trial_id.action, "subject": trial_id.subject,
           "take": trial_id.trial, "status": "failed", "warnings": []}
    t_start = time.perf_counter()
    try:
        trial = utd_mhad.load_trial(root, trial_id)
        rec["site"] = trial.site
        rec["samples"] = len(trial.accel)
        t0 = time.perf_counter()
        try:
            kb, motion, info = _keypoint_motion(trial, body)
        except imukit.Error as e:
            rec["reason"] = str(e)
            return rec
        rec["keypoints_seconds"] = time.perf_counter() - t0
        rec["keypoint_warnings"] = len(info["warnings"])
        imu = _series(trial)
        try:
            fit, note = _identify(kb, motion, imu, info, trial.site, FIT["correction"])
        except imukit.Error as e:
            rec["reason"] = str(e)
            return rec
        if note:
            rec["warnings"].append(note)
        rec["warnings"] += list(fit.warnings)
        rec["identify_seconds"] = fit.seconds
        rec["samples_used"] = int(fit.samples_used)
        rec["iterations"] = int(fit.iterations)
        rec["time_offset_s"] = float(fit.time_offset_s)
        rec["clock_rate"] = float(fit.clock_rate)
        rec["twist_rms_deg"] = float(np.degrees(np.sqrt(np.mean(fit.correction_angles ** 2))))
        rec["accel_bias_mps2"] = [float(v) for v in fit.accel_bias]
        rec["gyro_bias_radps"] = [float(v) for v in fit.gyro_bias]
        rec["fidelity"] = {"before": _fidelity(fit.fidelity_before),
                           "fit": _fidelity(fit.fidelity_after)}
        if rigid:
            try:
                r0, _ = _identify(kb, motion, imu, info, trial.site, "none")
                rec["fidelity"]["rigid"] = _fidelity(r0.fidelity_after)
                rec["identify_rigid_seconds"] = r0.seconds
            except imukit.Error as e:
                rec["warnings"].append(f"the fit without the twist failed: {e}")
        folder = os.path.join(out_dir, trial_id.stem)
        try:
            fit.write_scene(folder, motion, trial.site)
        except imukit.Error as e:
            rec["reason"] = str(e)
            return rec
        # What PPDA will use: the written scene, simulated again, against every real sample
        # ("scene") and against the samples the fit used ("scene_valid": the motion there is
        # inside the skeleton's span and clear of the stretches keypoints flagged).
        sim = imukit.read_scene(os.path.join(folder, "scene.json")).simulate()[trial.site]
        rec["fidelity"]["scene"] = _fidelity(
            imukit.fidelity(trial.accel, trial.gyro, sim.accel, sim.gyro))
        used = (np.asarray(fit.t) // IMU_PERIOD_NS).astype(int)
        rec["fidelity"]["scene_valid"] = _fidelity(
            imukit.fidelity(trial.accel[used], trial.gyro[used], sim.accel[used], sim.gyro[used]))
        rec["valid_samples"] = _runs(used)
        rec["status"] = "ok"
        return rec
    except (imukit.Error, ValueError) as e:  # unreadable files
        rec["reason"] = str(e)
        return rec
    finally:
        rec["seconds"] = time.perf_counter() - t_start


STAGES = ("before", "rigid", "fit", "scene", "scene_valid")


def _stats(values):
    v = np.asarray([x for x in values if np.isfinite(x)], dtype=float)
    if len(v) == 0:
        return None
    q1, med, q3 = np.percentile(v, [25, 50, 75])
    return {"median": float(med), "q1": float(q1), "q3": float(q3), "n": int(len(v))}


def summarize(records):
    """Per action class and over all trials: for each stage (before, rigid, fit, scene), sensor
    and measure, the median and quartiles of the per-axis values (the three axes of every trial
    pooled), and per axis; fit time per trial; the failures."""
    ok = [r for r in records if r["status"] == "ok"]
    groups = collections.OrderedDict()
    groups["all"] = ok
    for a in range(1, len(utd_mhad.ACTIONS) + 1):
        groups[str(a)] = [r for r in ok if r["action"] == a]
    table = {}
    for name, recs in groups.items():
        g = {"trials": len(recs)}
        for stage in STAGES:
            s = {}
            for sensor in ("accel", "gyro"):
                for measure in ("correlation", "rmse"):
                    per_axis = [[r["fidelity"][stage][sensor][measure][k] for r in recs
                                 if stage in r["fidelity"]] for k in range(3)]
                    s[f"{sensor}_{measure}"] = _stats(sum(per_axis, []))
                    s[f"{sensor}_{measure}_per_axis"] = [_stats(v) for v in per_axis]
            g[stage] = s
        table[name] = g
    seconds = [r["identify_seconds"] for r in ok]
    return {
        "schema": "imukit.utd_mhad_fidelity/1",
        "settings": {k: (list(v) if isinstance(v, tuple) else v) for k, v in FIT.items()},
        "trials": len(records), "fitted": len(ok),
        "failed": [{"trial": r["trial"], "reason": r.get("reason", "?")} for r in records
                   if r["status"] != "ok"],
        "identify_seconds": _stats(seconds),
        "clock_rate": _stats([r["clock_rate"] for r in ok]),
        "time_offset_s": _stats([r["time_offset_s"] for r in ok]),
        "twist_rms_deg": _stats([r["twist_rms_deg"] for r in ok]),
        "by_action": table,
        "records": records,
    }


def _finite(v):
    """NaN (an axis without variance has no correlation) as null: JSON has no NaN."""
    if isinstance(v, dict):
        return {k: _finite(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_finite(x) for x in v]
    if isinstance(v, float) and not np.isfinite(v):
        return None
    return v


def _cell(s, digits):
    if s is None:
        return "-"
    return f"{s['median']:.{digits}f} [{s['q1']:.{digits}f}, {s['q3']:.{digits}f}]"


def markdown(summary):
    """The fidelity table as markdown: per action class, per-axis correlation and RMSE (median
    [IQR] over the trials' axes) before the fit and of the written scene."""
    lines = [f"{summary['fitted']} of {summary['trials']} trials fitted; identify per trial "
             f"{_cell(summary['identify_seconds'], 3)} s (median [IQR], one thread).",
             "Per-axis values, median [IQR] over the trials' three axes. before: the motion as "
             "given (duration alignment, preset position, rotation by Wahba); rigid: placement, "
             "biases, timing fitted, no twist; fit: with the twist; scene: the written scene "
             "simulated again, all samples; valid: the same on the samples the fit used.", ""]
    for sensor, unit in (("gyro", "rad/s"), ("accel", "m/s^2")):
        for measure, label_m in (("correlation", "r"), ("rmse", f"RMSE {unit}")):
            lines += [f"| action | trials | {sensor} {label_m} before | rigid | fit | scene | valid |",
                      "|---|---|---|---|---|---|---|"]
            for name, g in summary["by_action"].items():
                label = "all" if name == "all" else f"{name} {utd_mhad.ACTIONS[int(name) - 1]}"
                cells = " | ".join(_cell(g[stage][f"{sensor}_{measure}"], 2) for stage in STAGES)
                lines.append(f"| {label} | {g['trials']} | {cells} |")
            lines.append("")
    if summary["failed"]:
        lines += ["Failed trials:", ""] + [f"- {f['trial']}: {f['reason']}" for f in summary["failed"]]
    return "\n".join(lines) + "\n"


def fit_dataset(root, out_dir, threads=2, trials=None, rigid=True, progress=None):
    """Fits every trial (or the TrialIds given) into out_dir (docs/formats.md, "Fitted scenes")
    on `threads` threads; writes out_dir/fidelity.json and fidelity.md and returns the summary."""
    if trials is None:
        trials, _ = utd_mhad.list_trials(root)
    os.makedirs(out_dir, exist_ok=True)
    bodies = subject_bodies(root, trials, threads)
    records = []
    with concurrent.futures.ThreadPoolExecutor(max_workers=threads) as pool:
        futures = [pool.submit(fit_trial, root, tid, out_dir, bodies.get(tid.subject), rigid)
                   for tid in trials]
        for i, f in enumerate(futures):
            records.append(f.result())
            if progress:
                progress(i + 1, len(futures), records[-1])
    summary = summarize(records)
    with open(os.path.join(out_dir, "fidelity.json"), "w") as f:
        json.dump(_finite(summary), f, indent=1, allow_nan=False)
        f.write("\n")
    with open(os.path.join(out_dir, "fidelity.md"), "w") as f:
        f.write(markdown(summary))
    return summary


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python3 -m imukit.datasets.utd_mhad_scenes",
                                 description=__doc__.splitlines()[0])
    ap.add_argument("root", help="the UTD-MHAD folder (Inertial/, Skeleton/)")
    ap.add_argument("out", help="output folder (one sub-folder per trial, fidelity.json/.md)")
    ap.add_argument("--threads", type=number(int, 1), default=2)
    ap.add_argument("--subjects", default="", help="comma list of subjects, e.g. s1,s4 or 1,4 (default all)")
    ap.add_argument("--limit", type=number(int, 1), help="only the first N trials (default all)")
    ap.add_argument("--no-rigid", action="store_true", help="skip the comparison fit without the twist")
    ap.add_argument("--correction", choices=("none", "twist", "rotation"), default=FIT["correction"],
                    help=f"segment correction (default {FIT['correction']})")
    ap.add_argument("--knot-spacing", type=float, default=FIT["knot_spacing_s"],
                    help=f"the correction's knot spacing, s (default {FIT['knot_spacing_s']})")
    args = ap.parse_args(argv)
    FIT["correction"] = args.correction
    FIT["knot_spacing_s"] = args.knot_spacing
    trials, unpaired = utd_mhad.list_trials(args.root)
    if args.subjects:
        try:
            keep = set(utd_mhad.parse_subjects(args.subjects))
        except ValueError as e:
            ap.error(f"--subjects: {e}")
        absent = sorted(keep - {t.subject for t in trials})
        if absent:
            ap.error(f"--subjects: no trials of subject(s) {', '.join(f's{s}' for s in absent)} in {args.root}")
        trials = [t for t in trials if t.subject in keep]
    if args.limit:
        trials = trials[:args.limit]

    def progress(i, n, rec):
        why = "" if rec["status"] == "ok" else f": {rec.get('reason', '')}"
        print(f"[{i}/{n}] {rec['trial']} {rec['status']}{why}", file=sys.stderr, flush=True)
    summary = fit_dataset(args.root, args.out, args.threads, trials, not args.no_rigid, progress)
    print(markdown(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
