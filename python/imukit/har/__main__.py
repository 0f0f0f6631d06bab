"""The HAR evaluation's experiments, one command each (docs/har.md):

    python3 -m imukit.har one-at-a-time  --utd-mhad DIR --scenes DIR --out DIR [--jobs 2] ...
    python3 -m imukit.har fewer-subjects --utd-mhad DIR --scenes DIR --out DIR ...
    python3 -m imukit.har sim-only       --utd-mhad DIR --scenes DIR --out DIR ...
    python3 -m imukit.har merge          --out DIR A/<experiment>.json B/<experiment>.json ...
    python3 -m imukit.har report         --out DIR

Each writes DIR/<experiment>.json (every finished run, appended as it ends: rerun the same
command to continue a killed experiment), DIR/<experiment>.md (tables) and DIR/<experiment>.png.
"""
import argparse
import os
import sys

from . import experiments, recordings as rec_format, report, utd_mhad
from .arguments import names, number, numbers
from .models import MODELS


def _data(args):
    """The recordings --recordings or --utd-mhad (with --scenes) names, only those of
    --subjects; ValueError naming the flag for what is not there (found in review: an unknown
    subject was dropped in silence, a missing --scenes folder was taken as no scenes)."""
    if args.scenes and not args.utd_mhad:
        raise ValueError("--scenes: only with --utd-mhad (labelled recordings name their scenes in recordings.json)")
    if args.scenes and not os.path.isdir(args.scenes):
        raise ValueError(f"--scenes: {args.scenes}: no such folder")
    wanted = None
    if args.recordings:
        R = rec_format.read_recordings(args.recordings)
        source = {"recordings": os.path.abspath(args.recordings)}
        if args.subjects:
            wanted = [s.strip() for s in args.subjects.split(",")]
    else:
        utd_subjects = None
        if args.subjects:
            try:
                utd_subjects = utd_mhad.reader.parse_subjects(args.subjects)
            except ValueError as e:
                raise ValueError(f"--subjects: {e}") from None
            wanted = [f"s{n}" for n in utd_subjects]
        try:
            R = utd_mhad.load(args.utd_mhad, scenes=args.scenes, subjects=utd_subjects)
        except FileNotFoundError as e:
            raise ValueError(f"--utd-mhad: {e}") from None
        source = {"utd_mhad": os.path.abspath(args.utd_mhad),
                  "scenes": os.path.abspath(args.scenes) if args.scenes else None}
    if wanted:
        unknown = [s for s in dict.fromkeys(wanted) if s not in R.subjects]
        if unknown:
            # (UTD-MHAD is read for the subjects asked for only: there is no list to show)
            have = f" (subjects: {', '.join(R.subjects)})" if args.recordings else ""
            raise ValueError(f"--subjects: no recordings of subject(s) {', '.join(unknown)} in "
                             f"{args.recordings or args.utd_mhad}{have}")
        R.recordings = [r for r in R.recordings if r.subject in wanted]
    if not len(R):
        raise ValueError(f"--utd-mhad: {args.utd_mhad}: no trials")
    source["recordings_count"] = len(R)
    source["rate_hz"] = R.rate_hz  # one rate, or a FormatError before any training
    source["fingerprints"] = experiments.subject_fingerprints(R)
    source["subjects"] = R.subjects
    return R, source


def _folds(args):
    return args.folds.split(",") if args.folds else None


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python3 -m imukit.har", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="command", required=True)
    common = argparse.ArgumentParser(add_help=False)
    src = common.add_mutually_exclusive_group()
    src.add_argument("--utd-mhad", help="UTD-MHAD folder (Inertial/, Skeleton/)")
    src.add_argument("--recordings", help="a labelled-recordings folder (imukit.recordings/1)")
    common.add_argument("--scenes", help="fitted scenes, one folder per UTD-MHAD trial (<a_s_t>/scene.json)")
    common.add_argument("--subjects", help="only these subjects (comma separated, e.g. s1,s2,s3)")
    common.add_argument("--out", required=True, help="results folder")
    common.add_argument("--models", type=names(MODELS), default="deepconvlstm,attend",
                        help=f"comma separated, of {', '.join(MODELS)} (default %(default)s)")
    common.add_argument("--arms", help="comma separated arms (default: the experiment's)")
    common.add_argument("--window", type=number(int, 2), default=50, help="samples per window")
    common.add_argument("--stride", type=number(int, 1), default=25, help="samples between window starts")
    common.add_argument("--epochs", type=number(int, 1), default=30)
    common.add_argument("--patience", type=number(int, 0), default=10,
                        help="stop after this many epochs without a better validation F1 (0: never)")
    common.add_argument("--batch-size", type=number(int, 1), default=64)
    common.add_argument("--policy", default="paper")
    common.add_argument("--tiny", action="store_true", help="tiny models (smoke tests)")
    common.add_argument("--jobs", type=number(int, 1), default=2, help="worker processes, one torch thread each")
    common.add_argument("--output-screen", type=number(float, 0), default=experiments.Settings.output_screen,
                        help="PPDA outputs above this many times the real peak (+ margin) stay real; "
                             "0 screens none, as runs before 2026-11-26 (default %(default)g)")
    common.add_argument("--steps-per-epoch", type=number(int, 0), default=0,
                        help="mini-batches per epoch; 0: one pass over the training windows (default). "
                             "A fixed count trains every training-set size alike (fewer-subjects)")
    folds = argparse.ArgumentParser(add_help=False)
    folds.add_argument("--folds", help="only the folds testing these subjects (comma separated; "
                       "default every subject): one experiment split across machines, see `merge`")
    one = sub.add_parser("one-at-a-time", parents=[common, folds])
    one.add_argument("--seeds", type=number(int, 1), default=3)
    one.add_argument("--options-all", action="store_true",
                     help="every grid option of each method (default: the middle option)")
    few = sub.add_parser("fewer-subjects", parents=[common])
    few.add_argument("--sizes", type=numbers(int, 1), default=[1, 2, 4, 6],
                     help="training subject counts (comma separated, default 1,2,4,6)")
    few.add_argument("--combinations", type=number(int, 1), default=10,
                     help="splits per size; the splits of fewer are the first of more")
    sim = sub.add_parser("sim-only", parents=[common, folds])
    sim.add_argument("--seeds", type=number(int, 1), default=1)
    fid = sub.add_parser("fidelity", parents=[common],
                         help="the identity re-simulation of every window against the real one")
    mrg = sub.add_parser("merge", help="one experiment's JSONs made apart (--folds) as one, then its report")
    mrg.add_argument("--out", required=True, help="folder for the merged <experiment>.json and its report")
    mrg.add_argument("inputs", nargs="+", help="the <experiment>.json files")
    rep = sub.add_parser("report")
    rep.add_argument("--out", required=True)
    args = ap.parse_args(argv)

    if args.command == "report":
        for name in ("one_at_a_time", "fewer_subjects", "sim_only"):
            path = os.path.join(args.out, f"{name}.json")
            if os.path.exists(path):
                print(report.write(experiments.read_results(path), args.out))
        return 0

    if args.command == "merge":
        import json
        doc = experiments.merge(args.inputs)
        os.makedirs(args.out, exist_ok=True)
        path = os.path.join(args.out, f"{doc['experiment']}.json")
        if any(os.path.abspath(p) == os.path.abspath(path) for p in args.inputs):
            ap.error(f"--out would overwrite the input {path}")
        with open(path, "w", encoding="utf-8") as f:
            json.dump(doc, f, indent=1)
            f.write("\n")
        print(report.write(doc, args.out))
        return 0

    if not (args.utd_mhad or args.recordings):
        ap.error("give --utd-mhad or --recordings")
    R, source = _data(args)
    if args.command == "fidelity":
        import json
        result = dict(experiments.window_fidelity(R, args.window, args.stride, args.policy), data=source)
        os.makedirs(args.out, exist_ok=True)
        with open(os.path.join(args.out, "fidelity_windows.json"), "w", encoding="utf-8") as f:
            json.dump(result, f, indent=1)
            f.write("\n")
        print(json.dumps(result, indent=1))
        return 0
    settings = experiments.Settings(window=args.window, stride=args.stride, epochs=args.epochs,
                                     patience=args.patience, batch_size=args.batch_size, tiny=args.tiny,
                                     policy=args.policy, output_screen=args.output_screen,
                                     steps_per_epoch=args.steps_per_epoch)
    state = experiments.prepare(R, settings)
    subjects = R.subjects
    if args.command == "one-at-a-time":
        arms = experiments.expand_arms(args.arms.split(",") if args.arms else experiments.ONE_AT_A_TIME_ARMS,
                                       options_all=args.options_all)
        runs = experiments.one_at_a_time_runs(subjects, arms, args.models, args.seeds, _folds(args))
        name = "one_at_a_time"
    elif args.command == "fewer-subjects":
        arms = experiments.expand_arms(args.arms.split(",") if args.arms else experiments.FEWER_SUBJECTS_ARMS)
        runs = experiments.fewer_subjects_runs(subjects, arms, args.models, args.sizes, args.combinations)
        name = "fewer_subjects"
    else:
        arms = ["baseline", "sim:identity"]
        runs = experiments.one_at_a_time_runs(subjects, arms, args.models, args.seeds, _folds(args))
        name = "sim_only"
    experiments.check_policy(settings.policy, arms)
    missing = experiments.check_scenes(R, arms)
    experiments.check_splits(runs, state)
    source["recordings_without_scene"] = missing
    # Only arms that re-simulate read the scenes: a baseline or STDA experiment continues on
    # scenes fitted again (review, 2026-11-27).
    if any(experiments.parse_arm(a).kind == "ppda" for a in arms):
        source["scene_fingerprints"] = experiments.scene_fingerprints(R)
    os.makedirs(args.out, exist_ok=True)
    store = experiments.ResultStore(os.path.join(args.out, f"{name}.json"), name, settings, source)
    for other in ("one_at_a_time", "sim_only", "fewer_subjects"):
        if other != name:
            experiments.reuse(runs, store, os.path.join(args.out, f"{other}.json"),
                              log=lambda s: print(s, flush=True))
    experiments.execute(runs, store, state, jobs=args.jobs, log=lambda s: print(s, flush=True))
    print(report.write(store.doc, args.out))
    return 0


def _main_with_clear_errors():
    # A bad file, a mismatched results JSON or an unknown fold is the user's to fix: one line
    # naming it, not a traceback. Inputs are checked where they are read and raise ValueError;
    # an OSError here is the file system's (an --out that cannot be written, a full disk).
    try:
        return main()
    except ValueError as e:
        print(f"python3 -m imukit.har: error: {e}", file=sys.stderr)
    except OSError as e:
        where = f"{e.filename}: " if e.filename else ""
        print(f"python3 -m imukit.har: error: {where}{e.strerror or e}", file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(_main_with_clear_errors())
