"""The experiments of the HAR evaluation (docs/har.md): arms, splits, resumable runs.

An *arm* says how training mini-batches are augmented:

| arm | meaning |
|---|---|
| `baseline` | real windows only |
| `stda:<method>:<option>`, `ppda:<method>:<option>` | one-at-a-time: half of the mini-batches under one sub-policy of the `paper` grid, the other half unaugmented; `<option>` is the grid option of the method's group (1-8; 1 for placement) |
| `stda:all`, `ppda:all` | one of the 810 sub-policies per mini-batch, uniformly |
| `stda:all:learned`, `ppda:all:learned` | the same with learned probabilities (GumbelPolicy) |
| `ppda-residual:...` | as `ppda:...`, but the sub-policy's change is added to the real window (real + re-simulated under the sub-policy - re-simulated with nothing changed): what the scene does not reproduce stays in |
| `sim:identity` | sim-only: every window re-simulated from its fitted scene, nothing else changed |

A *run* is (arm, model, test subject, validation subject, training subjects, seed); its result is
appended to the experiment's JSON as soon as it ends, so a killed experiment continues where it
stopped. Runs are spread over `jobs` worker processes of one torch thread each.
"""
import collections
import concurrent.futures.process
import dataclasses
import hashlib
import itertools
import json
import math
import multiprocessing
import os
import time

import numpy as np

import imukit

from . import augmentation, train, windows as windowing
from .recordings import read_json_file

# The six method pairs of the paper (Table I): the STDA method, the PPDA method, the sub-policy
# group and its option in the `paper` grid (index = ((a * 9 + s) * 2 + p) * 5 + h), and the
# option used when none is given: the middle of each grid, chosen before any run.
PAIRS = {
    "amplitude_scaling": ("magnitude scaling", "amplitude scaling", "a", range(1, 5), 2),
    "amplitude_warping": ("magnitude warping", "amplitude warping", "a", range(5, 9), 5),
    "speed_scaling": ("time scaling", "speed scaling", "s", range(1, 5), 3),
    "speed_warping": ("time warping", "speed warping", "s", range(5, 9), 5),
    "placement": ("rotation", "placement", "p", range(1, 2), 1),
    "hardware": ("jittering", "hardware", "h", range(1, 5), 2),
}
_GROUP_STRIDE = {"a": 90, "s": 10, "p": 5, "h": 1}


def grid_index(method, option):
    group, options = PAIRS[method][2], PAIRS[method][3]
    if option not in options:
        raise ValueError(f"{method}: option {option} is not one of {list(options)}")
    return _GROUP_STRIDE[group] * option


@dataclasses.dataclass(frozen=True)
class Arm:
    name: str
    kind: str                   # none | stda | ppda
    probabilities: tuple = ()   # over the policy's sub-policies; () for none
    learned: bool = False
    resimulate_identity: bool = False
    residual: bool = False      # PPDA as a change to the real window (BatchAugmenter)

    @property
    def label(self):
        parts = self.name.split(":")
        if self.name == "baseline":
            return "baseline (no augmentation)"
        if self.name == "sim:identity":
            return "sim-only (re-simulated windows)"
        kind = "PPDA residual" if self.residual else parts[0].upper()
        if parts[1] == "all":
            return f"{kind} all 810{' learned' if self.learned else ' uniform'}"
        stda_name, ppda_name = PAIRS[parts[1]][:2]
        return f"{kind} {stda_name if parts[0] == 'stda' else ppda_name}"


def parse_arm(name, policy_size=810):
    parts = name.split(":")
    if name == "baseline":
        return Arm(name, "none")
    if name == "sim:identity":
        p = np.zeros(policy_size)
        p[0] = 1.0
        return Arm(name, "ppda", tuple(p), resimulate_identity=True)
    if len(parts) >= 2 and parts[0] in ("stda", "ppda", "ppda-residual"):
        kind, residual = ("ppda", True) if parts[0] == "ppda-residual" else (parts[0], False)
        if parts[1] == "all" and len(parts) in (2, 3):
            if len(parts) == 3 and parts[2] != "learned":
                raise ValueError(f"arm '{name}': expected {parts[0]}:all or {parts[0]}:all:learned")
            return Arm(name, kind, tuple(np.full(policy_size, 1.0 / policy_size)),
                       learned=len(parts) == 3, residual=residual)
        if parts[1] in PAIRS and len(parts) in (2, 3):
            option = int(parts[2]) if len(parts) == 3 else PAIRS[parts[1]][4]
            p = np.zeros(policy_size)
            p[0] = 0.5
            p[grid_index(parts[1], option)] = 0.5
            return Arm(f"{parts[0]}:{parts[1]}:{option}", kind, tuple(p), residual=residual)
    raise ValueError(f"unknown arm '{name}' (baseline, stda|ppda|ppda-residual:<method>[:<option>], "
                     f"stda|ppda|ppda-residual:all[:learned], sim:identity; methods: {', '.join(PAIRS)})")


ONE_AT_A_TIME_ARMS = (["baseline"] + [f"stda:{m}" for m in PAIRS] + [f"ppda:{m}" for m in PAIRS])
FEWER_SUBJECTS_ARMS = ["baseline", "stda:all", "ppda:all", "ppda:all:learned"]


# The protocol of this code (Settings.protocol).
PROTOCOL = 2


@dataclasses.dataclass
class Settings:
    """What every run of an experiment shares (recorded in the JSON; a resumed experiment must
    have the same)."""
    window: int = 50
    stride: int = 25
    epochs: int = 30
    patience: int = 10
    batch_size: int = 64
    tiny: bool = False
    policy: str = "paper"
    learn_every: int = 4
    learn_lr: float = 0.01
    # PPDA outputs peaking above this many times the real window's peak (plus the margin) are
    # trained on as the real window; 0 screens none. 8 = the identity screen's 2 times the
    # paper grid's fastest speed factor squared (2.0^2, the accelerations of a motion played
    # twice as fast): no output the grid can make from a usable window exceeds it, while a
    # sped-up window reading a neighbour's tracking failure does (docs/har.md).
    output_screen: float = 8.0
    # Mini-batches per epoch, 0: one pass over the training windows (train.TrainConfig).
    steps_per_epoch: int = 0
    # What a run of this code computes, as a number raised whenever the code changes what an
    # existing arm computes without any setting changing (found in review, 2026-11-27: results
    # recorded no code version, so a resumed, reused or merged experiment could hold runs of
    # two definitions of one arm under one name). Being a setting, results of another protocol
    # are refused by resume, `reuse` and `merge` like other settings. 1: every result up to
    # 2026-11-27 (JSON without the key); 2: after that day's review (the learned arms draw their
    # validation batches from their own stream, train.Trainer.fit).
    protocol: int = PROTOCOL


# Settings keys added after results were written, with the value those results were made with:
# a JSON without the key continues only under that value.
LEGACY_SETTINGS = {"output_screen": 0.0, "steps_per_epoch": 0, "protocol": 1}


def settings_of(doc):
    """A results document's settings, keys it predates filled with their LEGACY_SETTINGS value."""
    return {**LEGACY_SETTINGS, **(doc.get("settings") or {})}


def run_key(run):
    return "|".join([run["arm"], run["model"], f"test={run['test']}", f"val={run['val']}",
                     "train=" + ",".join(run["train"]), f"seed={run['seed']}"])


# ---- one run, in a worker process ----------------------------------------------------------

_STATE = {}


def read_policy(name):
    """The policy `--policy` names (a built-in grid or an `imukit.policy/1` file)."""
    try:
        return imukit.read_policy(name)
    except imukit.Error as e:
        raise ValueError(f"--policy: {e}") from None


def prepare(recordings, settings):
    """What every run of an experiment shares: the policy, the windows of every recording and
    their subjects. Built once, in the process that starts the workers (they inherit it), so a
    bad window, policy or recordings of different channel counts or rates is one error before
    any run (found in review: built in the pool's initializer, such an error made
    multiprocessing start new workers forever)."""
    policy = read_policy(settings.policy)
    W = windowing.make_windows(recordings, settings.window, settings.stride)
    return {"recordings": recordings, "settings": settings, "windows": W, "policy": policy, "ppda": None,
            "subject": np.array([recordings[i].subject for i in W.recording]), "code": code_version()}


def _init_worker(state, abort=None, started=None):
    # Never raises: a pool whose initializer raises replaces the worker and calls it again,
    # forever. The error is kept for run_one, whose error the pool hands to the caller.
    # `abort` (an Event) is set by the parent once a run failed: the runs not yet begun are
    # skipped (run_one returns None). `started` (a SimpleQueue) gets the key of each run the
    # worker begins (execute).
    _STATE.clear()
    _STATE["abort"] = abort
    _STATE["started"] = started
    try:
        train.set_threads(1)
        _STATE.update(state)
    except Exception as e:
        _STATE["error"] = e


def check_splits(runs, state):
    """Refuses runs whose training, validation or test subjects have no window (found in
    review: no training window was a torch traceback, no validation window kept the first
    epoch's model with validation F1 0.0, no test window reported test accuracy NaN)."""
    counts = collections.Counter(state["subject"].tolist())
    for run in runs:
        for role, subjects in (("training", run["train"]), ("validation", [run["val"]]), ("test", [run["test"]])):
            if not any(counts[s] for s in subjects):
                raise ValueError(
                    f"the fold testing {run['test']} (validation {run['val']}) has no {role} window: "
                    f"subject(s) {', '.join(subjects) or '(none)'} have no labelled window of "
                    f"{state['settings'].window} samples (recordings shorter than the window, or unlabelled)")


def run_one(run):
    """Trains and tests one run (a dict: arm, model, test, val, train, seed); returns it with
    its results; None when skipped because another run failed."""
    if _STATE.get("abort") is not None and _STATE["abort"].is_set():
        return None
    if "error" in _STATE:
        raise _STATE["error"]
    check_splits([run], _STATE)
    R, s, W, policy = _STATE["recordings"], _STATE["settings"], _STATE["windows"], _STATE["policy"]
    subject = _STATE["subject"]
    arm = parse_arm(run["arm"], len(policy))
    tr = W.subset(np.isin(subject, run["train"]))
    va = W.subset(subject == run["val"])
    te = W.subset(subject == run["test"])
    standardize = windowing.Standardizer.fit(tr.X)
    ppda = None
    if arm.kind == "ppda":
        if _STATE["ppda"] is None:
            _STATE["ppda"] = augmentation.PpdaSource(R, s.window)
        ppda = _STATE["ppda"]
    augmenter = augmentation.BatchAugmenter(arm.kind, policy, tr, standardize, ppda=ppda,
                                            resimulate_identity=arm.resimulate_identity, residual=arm.residual,
                                            output_screen=s.output_screen)
    if arm.learned:
        sampler = augmentation.GumbelPolicy(len(policy), run["seed"], lr=s.learn_lr, every=s.learn_every)
    else:
        p = arm.probabilities if arm.kind != "none" else np.eye(1, len(policy))[0]
        sampler = augmentation.SubPolicySampler(p, run["seed"])
    config = train.TrainConfig(model=run["model"], tiny=s.tiny, epochs=s.epochs, patience=s.patience,
                               batch_size=s.batch_size, steps_per_epoch=s.steps_per_epoch,
                               seed=run["seed"], threads=1)
    trainer = train.Trainer(config, len(R.classes), R.channels, augmenter, sampler)
    result = trainer.fit(tr, standardize(va.X), va.y, standardize(te.X), te.y)
    result["train_f1"], result["train_acc"] = train.evaluate(trainer.model, standardize(tr.X), tr.y)
    result["windows"] = {"train": len(tr), "val": len(va), "test": len(te)}
    result["unfitted_windows"] = augmenter.unfitted_windows
    result["outside_scene_windows"] = augmenter.outside_scene_windows
    result["implausible_windows"] = augmenter.implausible_windows
    result["implausible_outputs"] = augmenter.implausible_outputs
    result["too_short_windows"] = augmenter.too_short_windows
    result["code"] = _STATE.get("code")
    return dict(run, **result)


# ---- experiments -----------------------------------------------------------------------------

def loso_splits(subjects):
    """Leave-one-subject-out: test subject i, validation subject i + 1 (cyclic), training the rest."""
    if len(subjects) < 3:
        raise ValueError(f"leave-one-subject-out needs 3 subjects or more (one tested, one validating, "
                         f"the others training), got {len(subjects)}: {', '.join(subjects)}")
    out = []
    for i, t in enumerate(subjects):
        v = subjects[(i + 1) % len(subjects)]
        out.append((t, v, [s for s in subjects if s not in (t, v)]))
    return out


def one_at_a_time_runs(subjects, arms, models, seeds, folds=None):
    """Every arm on every leave-one-subject-out fold; `folds` (test subjects) keeps only those
    folds, so one experiment can be split across machines and its JSONs merged."""
    if folds is not None:
        unknown = sorted(set(folds) - set(subjects))
        if unknown:
            raise ValueError(f"--folds: no subject(s) {unknown} among {subjects}")
    return [{"arm": a, "model": m, "test": t, "val": v, "train": tr, "seed": s}
            for m in models for s in range(seeds) for (t, v, tr) in loso_splits(subjects)
            if folds is None or t in folds for a in arms]


def fewer_subjects_runs(subjects, arms, models, sizes, combinations, seed=0):
    """For n training subjects: up to `combinations` splits; split j tests subject j mod S,
    validates on the next one and trains on a random n-subset of the other S - 2, listed in the
    subjects' order (all of them for n = S - 2: the first `combinations` LOSO folds, the runs
    of one-at-a-time's baseline). Split j draws from its own stream, default_rng([20250601, n,
    j]), so the splits of fewer combinations are the first ones of more, whatever the other
    sizes (found in review: one stream for all made them depend on both). A subset the fold
    already has is drawn again; a fold with every subset taken gets no further split. Seed 0
    for every run (the spread is over subject subsets)."""
    folds = loso_splits(subjects)
    runs = []
    for n in sizes:
        if not 1 <= n <= len(subjects) - 2:
            raise ValueError(f"--sizes: {n} training subjects: expected 1 to {len(subjects) - 2} "
                             f"(of {len(subjects)} subjects one is tested, one validates)")
        splits, taken = [], collections.defaultdict(set)
        for j in range(combinations):
            t, v, rest = folds[j % len(folds)]
            if len(taken[t]) == math.comb(len(rest), n):
                continue
            rng = np.random.default_rng([20250601, n, j])
            train_set = None
            while train_set is None or train_set in taken[t]:
                chosen = set(rng.choice(rest, size=n, replace=False).tolist())
                train_set = tuple(s for s in rest if s in chosen)
            taken[t].add(train_set)
            splits.append((t, v, list(train_set)))
        for m in models:
            for (t, v, tr) in splits:
                for a in arms:
                    runs.append({"arm": a, "model": m, "test": t, "val": v, "train": tr, "seed": seed,
                                 "n_train": n})
    return runs


def subject_fingerprints(recordings):
    """Per subject, a digest of what its runs are trained and tested on: each recording's id,
    length, channels and rate, and whether it has a scene (folders move between machines, so
    paths would not do; a subset of subjects keeps the others' digests)."""
    rows = {}
    for r in recordings.recordings:
        rows.setdefault(r.subject, []).append(
            f"{r.id}:{r.samples.shape[0]}x{r.samples.shape[1]}@{r.rate_hz!r}:{r.scene is not None}")
    return {s: hashlib.sha256("\n".join(sorted(v)).encode()).hexdigest()[:16] for s, v in rows.items()}


def scene_fingerprints(recordings):
    """Per subject with scenes, a digest of what PPDA re-simulates: each fitted scene's file and
    the motion files it names (their bytes), its time offset and biases. subject_fingerprints
    says only whether a recording has a scene; scenes fitted again by another version of imukit
    differ here (review, 2026-11-27: results of two fits were indistinguishable)."""
    rows = {}
    for r in recordings.recordings:
        if r.scene is None:
            continue
        h = hashlib.sha256()
        with open(r.scene.path, "rb") as f:
            text = f.read()
        h.update(text)
        try:
            motion = json.loads(text).get("motion") or {}
        except (ValueError, AttributeError):
            motion = {}
        folder = os.path.dirname(r.scene.path)
        for key in sorted(motion) if isinstance(motion, dict) else []:
            name = motion[key]
            if isinstance(name, str) and os.path.isfile(os.path.join(folder, name)):
                with open(os.path.join(folder, name), "rb") as f:
                    h.update(f"{key}={name}:".encode())
                    h.update(f.read())
        bias = None if r.scene.bias is None else np.asarray(r.scene.bias, dtype=np.float64).tolist()
        h.update(f"{r.scene.sensors!r}:{float(r.scene.time_offset_s)!r}:{bias!r}".encode())
        rows.setdefault(r.subject, []).append(f"{r.id}:{h.hexdigest()}")
    return {s: hashlib.sha256("\n".join(sorted(v)).encode()).hexdigest()[:16] for s, v in rows.items()}


DIGESTS = ("fingerprints", "scene_fingerprints")


def read_results(path):
    """An experiment's JSON (what ResultStore writes); ValueError naming the file when it cannot
    be read or is not one (found in review: a corrupt file's error did not say which, another
    JSON was a KeyError traceback)."""
    doc = read_json_file(path)
    if not (isinstance(doc, dict) and isinstance(doc.get("experiment"), str)
            and isinstance(doc.get("settings"), dict) and isinstance(doc.get("runs"), list)):
        raise ValueError(f"{path}: not an experiment's results (expected the JSON object "
                         "`python3 -m imukit.har` writes: experiment, settings, runs)")
    return doc


def data_mismatch(old, new):
    """The subjects whose recordings or scenes differ between two experiments' data (JSONs
    written before a digest was recorded match anything in it)."""
    differ = set()
    for key in DIGESTS:
        a, b = (old or {}).get(key) or {}, (new or {}).get(key) or {}
        differ |= {s for s in set(a) & set(b) if a[s] != b[s]}
    return sorted(differ)


def protocol_differs(old, new, path):
    """ValueError naming `path` when settings `old` and `new` are of different protocols
    (Settings.protocol): the runs of one would be taken as the other's."""
    if old["protocol"] != new["protocol"]:
        raise ValueError(f"{path}: made by protocol {old['protocol']} of imukit.har, this is protocol "
                         f"{new['protocol']} (what some arms compute changed: docs/har.md, \"Protocol "
                         "versions\"); its runs cannot be continued or mixed with this one's: use another --out")


def code_version():
    """The package's version and, when it lies in a git work tree (a build inside the
    repository), `git describe --always --dirty` of it: recorded per run (`code`) so a result
    says which code made it (found in review, 2026-11-27); '' parts when unknown."""
    import subprocess
    try:
        git = subprocess.run(["git", "-C", os.path.dirname(os.path.abspath(__file__)), "describe", "--always",
                              "--dirty"], capture_output=True, text=True, timeout=20)
        describe = git.stdout.strip() if git.returncode == 0 else ""
    except (OSError, subprocess.SubprocessError):
        describe = ""
    return {"imukit": getattr(imukit, "__version__", ""), "git": describe}


class ResultStore:
    """The experiment's JSON: settings plus one entry per finished run, rewritten atomically
    after each run. Refuses to continue a JSON written with other settings or other data."""

    def __init__(self, path, experiment, settings, data):
        self.path = path
        self.doc = {"schema": "imukit.har/1", "experiment": experiment,
                    "settings": dataclasses.asdict(settings), "data": data, "runs": []}
        if os.path.exists(path):
            old = read_results(path)
            protocol_differs(settings_of(old), self.doc["settings"], path)
            if settings_of(old) != self.doc["settings"] or old.get("experiment") != experiment:
                raise ValueError(f"{path}: written with other settings {old.get('settings')}; "
                                 "use another --out or delete it")
            # Found in review: results of another dataset counted as done for this one.
            differ = data_mismatch(old.get("data"), data)
            if differ:
                raise ValueError(f"{path}: written from other recordings or scenes of subject(s) {differ}; "
                                 "use another --out or delete it")
            merged = dict(old.get("data") or {})
            merged.update(data)
            for key in DIGESTS:
                merged[key] = {**((old.get("data") or {}).get(key) or {}), **(data.get(key) or {})}
            merged["subjects"] = list(dict.fromkeys((old.get("data") or {}).get("subjects", []) +
                                                    list(data.get("subjects", []))))
            merged["recordings_count"] = max((old.get("data") or {}).get("recordings_count", 0),
                                             data.get("recordings_count", 0))
            self.doc["data"] = merged
            self.doc["runs"] = old.get("runs", [])
            self.doc["wall_seconds"] = old.get("wall_seconds", 0.0)
        self.done = {run_key(r) for r in self.doc["runs"]}

    def add(self, result):
        self.doc["runs"].append(result)
        self.done.add(run_key(result))
        self.save()

    def save(self):
        tmp = self.path + ".tmp"
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump(self.doc, f, indent=1)
            f.write("\n")
        os.replace(tmp, self.path)


def reuse(runs, store, other_path, log=print):
    """Copies into `store` the runs another experiment's JSON (same settings) already has: the
    same arm, model, split and seed give the same result (fewer-subjects' 6-subject baseline is
    the one-at-a-time baseline)."""
    if not os.path.exists(other_path):
        return 0
    other = read_results(other_path)
    # Another protocol's runs are never copied (its other settings may well agree).
    if settings_of(other) != store.doc["settings"] or data_mismatch(other.get("data"), store.doc["data"]):
        return 0
    have = {run_key(r): r for r in other.get("runs", [])}
    copied = 0
    for run in runs:
        k = run_key(run)
        if k in have and k not in store.done:
            store.add(dict(have[k], **run, reused_from=os.path.basename(other_path)))
            copied += 1
    if copied:
        log(f"{copied} run(s) taken from {other_path}")
    return copied


def merge(paths):
    """One experiment's JSONs made apart (e.g. `--folds` on two machines) as one document for the
    report. They must share the experiment and settings, and no run may be in two of them. Where
    their data differ (a subject's recordings, which recordings have a scene) the merged document
    says so: `data.parts` keeps each file's data and the tests of its runs, and
    `data.fingerprints_differ` lists the subjects whose recordings' digests disagree and
    `data.scenes_differ` those whose scenes' do, so a table made from it can name what was not
    trained on the same data."""
    docs = [read_results(p) for p in paths]
    first = docs[0]
    seen = {}
    for p, d in zip(paths, docs):
        protocol_differs(settings_of(first), settings_of(d), p)
        if d.get("experiment") != first.get("experiment") or settings_of(d) != settings_of(first):
            raise ValueError(f"{p}: experiment {d.get('experiment')!r} with settings {settings_of(d)} "
                             f"differs from {paths[0]}: {first.get('experiment')!r} with {settings_of(first)}")
        for r in d.get("runs", []):
            k = run_key(r)
            if k in seen:
                raise ValueError(f"{p}: run {k} is in {seen[k]} too")
            seen[k] = p
    digests = {key: {} for key in DIGESTS}
    for d in docs:
        for key in DIGESTS:
            for s, h in ((d.get("data") or {}).get(key) or {}).items():
                digests[key].setdefault(s, set()).add(h)
    parts = [{"file": os.path.basename(os.path.dirname(os.path.abspath(p))) + "/" + os.path.basename(p),
              "tests": sorted({r["test"] for r in d.get("runs", [])}), "runs": len(d.get("runs", [])),
              "data": d.get("data")} for p, d in zip(paths, docs)]
    data = dict(first.get("data") or {})
    data["subjects"] = list(dict.fromkeys(s for d in docs for s in (d.get("data") or {}).get("subjects", [])))
    data["fingerprints_differ"] = sorted(s for s, h in digests["fingerprints"].items() if len(h) > 1)
    data["scenes_differ"] = sorted(s for s, h in digests["scene_fingerprints"].items() if len(h) > 1)
    data["parts"] = parts
    return {"schema": first.get("schema"), "experiment": first.get("experiment"),
            "settings": settings_of(first), "data": data,
            "runs": [r for d in docs for r in d.get("runs", [])],
            "wall_seconds": sum(d.get("wall_seconds", 0.0) for d in docs)}


def execute(runs, store, state, jobs=1, log=print):
    """Runs what the store does not have yet, `jobs` at a time, from `state` (prepare());
    returns the wall time."""
    pending = [r for r in runs if run_key(r) not in store.done]
    log(f"{len(runs) - len(pending)} of {len(runs)} runs already done, {len(pending)} to go, {jobs} job(s)")
    t0 = time.perf_counter()
    wall0 = store.doc.get("wall_seconds", 0.0)

    def finished(i, r):
        store.doc["wall_seconds"] = wall0 + time.perf_counter() - t0
        store.add(r)
        log(f"[{i + 1}/{len(pending)}] {run_key(r)}: test F1 {r['test_f1']:.4f} (val {r['val_f1']:.4f}, "
            f"epoch {r['best_epoch']}/{r['epochs_run']}, {r['seconds']:.0f} s, imukit {100 * r['imukit_share']:.1f} %)")

    if jobs <= 1 or len(pending) <= 1:
        _init_worker(state)
        for i, run in enumerate(pending):
            finished(i, run_one(run))
        return time.perf_counter() - t0
    # A failed run ends the experiment after the runs under way finish (their results are kept)
    # and the rest are skipped. Terminating the workers at the first error could kill one in the
    # middle of handing back a result, holding the result queue's lock, and the pool's own
    # shutdown then waited for that lock forever (seen under load, review of 2026-11-27).
    # A worker that dies (the OOM killer, a crash in native code) ends the experiment with an
    # error naming the runs it lost: concurrent.futures notices a dead worker and fails the
    # futures (BrokenProcessPool), where multiprocessing.Pool replaced the worker and waited for
    # its lost run forever (found in review, 2026-11-27). Each worker says which run it starts
    # (`started`, written before the run begins), so the runs lost are those started and not
    # handed back.
    ctx = multiprocessing.get_context("fork")
    abort = ctx.Event()
    started = ctx.SimpleQueue()
    failure, broken, i = None, False, 0
    begun, handed_back = set(), set()

    def drain():  # read as the runs go: a full pipe would block the workers' next announcement
        while not started.empty():
            begun.add(started.get())
    with concurrent.futures.ProcessPoolExecutor(jobs, mp_context=ctx, initializer=_init_worker,
                                                initargs=(state, abort, started)) as pool:
        futures = {pool.submit(_run_announced, run_one, run): run for run in pending}
        for future in concurrent.futures.as_completed(futures):
            drain()
            try:
                r = future.result()
            except concurrent.futures.process.BrokenProcessPool:
                broken = True
                continue
            except Exception as e:  # noqa: BLE001 (any run's error ends the experiment)
                handed_back.add(run_key(futures[future]))
                if failure is None:
                    failure = e
                    abort.set()
                continue
            handed_back.add(run_key(futures[future]))
            if r is not None:
                finished(i, r)
                i += 1
    if broken:
        drain()
        lost = sorted(begun - handed_back)
        raise RuntimeError(f"a worker process died (killed, e.g. by the out-of-memory killer, or crashed in "
                           f"native code) while running {' or '.join(lost) or 'a run'}; the other runs "
                           f"under way were stopped with it. The {i} run(s) finished are saved in "
                           f"{getattr(store, 'path', 'the results')}: run the same command again to "
                           "continue")
    if failure is not None:
        raise failure
    return time.perf_counter() - t0


def _run_announced(run_fn, run):
    """run_fn(run) in a worker, its run key told to the parent first (execute)."""
    if _STATE.get("started") is not None and not (_STATE.get("abort") is not None and _STATE["abort"].is_set()):
        _STATE["started"].put(run_key(run))
    return run_fn(run)


def check_policy(policy, arms):
    """Refuses a policy other than `paper` for any arm but the baseline: the arms name sub-policies
    by their place in the `paper` grid (the identity first, grid_index's strides), and PPDA
    re-simulates with that grid's parameters. Found in review, 2026-11-27: with another
    `--policy` they silently selected other sub-policies, or failed at their first run after the
    runs before it had finished."""
    named = [a for a in arms if a != "baseline"]
    if policy != "paper" and named:
        raise ValueError(f"--policy {policy}: the arms {', '.join(named)} are defined on the `paper` grid "
                         "(sub-policies named by their place in it); only `baseline` runs under another "
                         "policy")


def expand_arms(arms, options_all=False):
    out = []
    for a in arms:
        parts = a.split(":")
        if options_all and len(parts) == 2 and parts[1] in PAIRS:
            out += [f"{a}:{o}" for o in PAIRS[parts[1]][3]]
        else:
            out.append(parse_arm(a).name)
    return list(dict.fromkeys(out))


def check_scenes(recordings, arms):
    """The recordings without a fitted scene (their PPDA windows stay real); an error when no
    recording has one and a PPDA (or sim) arm is asked for, or when a recording's scene cannot
    be read, lacks a sensor the recording names or samples at another rate. Found in review,
    2026-11-27: such a scene failed only when a PPDA run first used it, possibly after hours of
    other runs. Each scene file is read once (read_scene does not simulate)."""
    missing = [r.id for r in recordings.recordings if r.scene is None]
    if not any(parse_arm(a).kind == "ppda" for a in arms):
        return missing
    if len(missing) == len(recordings):
        raise ValueError("PPDA arms need fitted scenes and no recording has one: give --scenes")
    scenes = {}  # path -> (rate, sensor names), as PpdaSource.augmenter sees them
    for r in recordings.recordings:
        if r.scene is None:
            continue
        path = r.scene.path
        where = f"{recordings.name}: recording {r.id}: scene {path}"
        if path not in scenes:
            try:
                scene = imukit.read_scene(path)
            except imukit.Error as e:
                # imukit's message names the file at fault: the scene (named once here, with its
                # line:column when there is one), or a motion file the scene names.
                text = str(e)
                text = text[len(path):] if text.startswith(path) else f": {text}"
                raise ValueError(f"{where}{text}") from None
            scenes[path] = (scene.rate_hz, list(scene.sensors))
        rate, names = scenes[path]
        absent = [s for s in r.scene.sensors if s not in names]
        if absent:
            raise ValueError(f"{where}: no sensor {absent} (the scene has {names})")
        if abs(rate - r.rate_hz) > 1e-9 * r.rate_hz:
            raise ValueError(f"{where}: the scene samples at {rate:g} Hz, the recording at {r.rate_hz:g} Hz")
    return missing


def window_fidelity(recordings, window, stride, policy="paper"):
    """How close PPDA's starting point is to the real data: every window of a recording with a
    fitted scene (and inside it: `outside_scene_windows` counts the others) re-simulated under
    the identity sub-policy (fitted biases added) against the real window, in SI units. Per
    sensor kind: the per-window, per-axis correlation (median and quartiles), the per-window
    RMSE (median) beside the real signal's standard deviation, and how many re-simulated
    windows peak above the largest real value of the whole dataset."""
    W = windowing.make_windows(recordings, window, stride)
    source = augmentation.PpdaSource(recordings, window, policy=read_policy(policy))
    fitted = np.array([recordings[i].scene is not None for i in W.recording], bool)
    inside = source.inside_scene(W.recording, W.start)
    if not fitted.any():
        raise ValueError(f"none of the {len(W)} windows has a fitted scene to compare with: "
                         "give --scenes (UTD-MHAD) or recordings with a scene")
    if not inside.any():
        raise ValueError(f"none of the {int(fitted.sum())} windows with a fitted scene lies inside its scene")
    Wf = W.subset(inside)
    X = np.empty_like(Wf.X)
    source.resimulate(Wf.recording, Wf.start, X)
    # Figures over every fitted window inside its scene, the implausible ones (which training
    # keeps real) included.
    out = {"windows": int(len(W)), "fitted_windows": int(fitted.sum()),
           "outside_scene_windows": int((fitted & ~inside).sum()),
           "implausible_windows": sum(not source.plausible(r, x) for r, x in zip(Wf.X, X))}
    for name, lo in (("accel", 0), ("gyro", 3)):
        real, sim = Wf.X[..., lo:lo + 3], X[..., lo:lo + 3]
        rc = real - real.mean(axis=1, keepdims=True)
        sc = sim - sim.mean(axis=1, keepdims=True)
        den = np.sqrt((rc ** 2).sum(axis=1) * (sc ** 2).sum(axis=1))
        ok = den > 1e-12
        r = ((rc * sc).sum(axis=1)[ok] / den[ok])
        rmse = np.sqrt(np.mean((real - sim) ** 2, axis=(1, 2)))
        q1, med, q3 = np.percentile(r, [25, 50, 75])
        out[name] = {"correlation": {"median": float(med), "q1": float(q1), "q3": float(q3)},
                     "rmse_median": float(np.median(rmse)), "real_std": float(real.std()),
                     "real_max_abs": float(np.abs(W.X[..., lo:lo + 3]).max()),
                     "windows_peaking_above_real_max": int((np.abs(sim).max(axis=(1, 2)) >
                                                            np.abs(W.X[..., lo:lo + 3]).max()).sum())}
    out["outputs"] = output_peaks(source, Wf, policy)
    return out


OUTPUT_PEAK_FACTORS = (2.0, 4.0, 8.0)


def output_peaks(source, Wf, policy):
    """What the usable-window screen does not see: each PPDA method's one-at-a-time sub-policy
    applied to every usable window (seed 1), counted where its output peaks above f times the
    real window's peak plus PpdaSource.PEAK_MARGIN, for each f of OUTPUT_PEAK_FACTORS, and how
    many of those above the largest f lie next to a window the screen keeps real (a sped-up
    window reads motion beyond its own span). A scaled joint angle that jumps
    (docs/augmentation.md) shows here too. Training screens outputs above
    Settings.output_screen (docs/har.md)."""
    usable = source.usable(Wf.recording, Wf.start)
    order = np.flatnonzero(usable)
    order = order[np.argsort(Wf.recording[order], kind="stable")]

    def beside_kept_real(j):  # Wf holds every window of a fitted recording, in start order
        return any(0 <= n < len(Wf) and Wf.recording[n] == Wf.recording[j] and not usable[n]
                   for n in (j - 1, j + 1))
    P = source.identity_policy
    top = f"{OUTPUT_PEAK_FACTORS[-1]:g}x"
    out = {"usable_windows": int(len(order))}
    for method, pair in PAIRS.items():
        k = grid_index(method, pair[4])
        Y = np.empty((len(order),) + Wf.X.shape[1:], np.float32)
        # A policy faster than the paper grid's options may need more motion than a short
        # trial has: such windows are counted, not judged.
        too_short = np.zeros(len(order), bool)
        source.apply(k, Wf.recording[order], Wf.start[order], imukit.Rng(1), P, Y, too_short)
        above = {f: [j for j, y, short in zip(order, Y, too_short)
                     if not short and not source.plausible(Wf.X[j], y, f)]
                 for f in OUTPUT_PEAK_FACTORS}
        out[method] = {"sub_policy": repr(P[k]), "too_short": int(too_short.sum()),
                       "above": {f"{f:g}x": len(js) for f, js in above.items()},
                       f"above_{top}_beside_a_window_kept_real":
                           sum(beside_kept_real(j) for j in above[OUTPUT_PEAK_FACTORS[-1]])}
    return out
