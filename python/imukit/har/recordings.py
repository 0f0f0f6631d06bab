"""Labelled recordings (`imukit.recordings/1`): any HAR dataset as IMU samples with labels.

A folder with `recordings.json` and one `.npy` per recording (docs/formats.md, "Labelled
recordings"): per recording the samples (N x 6 per sensor, `ax ay az gx gy gz`, m/s^2 and rad/s),
the rate, the sensors' names, the subject, and the labels (one per trial, or one per sample in an
int64 `.npy`, -1 = unlabelled); optionally the recording's fitted scene (`imukit.scene/1`) for
physically plausible augmentation, with the scene's sensor names and the time offset between the
two streams.

Errors name the file and the JSON path (`recordings.json: recordings[3].label: 27 is not a class
index 0..26`).
"""
import dataclasses
import json
import os

import numpy as np

SCHEMA = "imukit.recordings/1"


class FormatError(ValueError):
    """A labelled-recordings folder that does not follow the format (the message names where)."""


@dataclasses.dataclass
class SceneRef:
    """The fitted scene of one recording: PPDA re-simulates the recording through it.

    path: the scene file (`imukit.scene/1`); sensors: the scene's sensor names in the order of
    the recording's sensors; time_offset_s: the recording's sample at time t (from its first
    sample) saw the scene's motion at t + time_offset_s (the identified placement's
    `timing.time_offset_s`); bias: optional constant offsets (sensors, 6) -- ax ay az (m/s^2)
    gx gy gz (rad/s) per sensor -- added to every re-simulated sample (the fitted hardware's
    biases: `imukit.Augmenter` leaves a scene's hardware out)."""
    path: str
    sensors: list
    time_offset_s: float = 0.0
    bias: np.ndarray = None


@dataclasses.dataclass
class Recording:
    id: str
    subject: str
    samples: np.ndarray   # (N, 6 x sensors) float64: per sensor ax ay az (m/s^2) gx gy gz (rad/s)
    labels: np.ndarray    # (N,) int64 class index per sample, -1 = unlabelled
    rate_hz: float
    sensors: list         # sensor names (e.g. ["right_wrist"]), 6 channels each
    scene: SceneRef = None

    def __len__(self):
        return len(self.samples)


@dataclasses.dataclass
class Recordings:
    name: str
    classes: list         # class k is classes[k]
    recordings: list      # of Recording

    def __len__(self):
        return len(self.recordings)

    def __getitem__(self, i):
        return self.recordings[i]

    @property
    def subjects(self):
        """Subject ids in order of first appearance."""
        return list(dict.fromkeys(r.subject for r in self.recordings))

    @property
    def channels(self):
        counts = {r.samples.shape[1] for r in self.recordings}
        if len(counts) != 1:
            raise FormatError(f"{self.name}: recordings have different channel counts {sorted(counts)}")
        return counts.pop()

    @property
    def rate_hz(self):
        rates = {r.rate_hz for r in self.recordings}
        if len(rates) != 1:
            raise FormatError(f"{self.name}: recordings at different rates {sorted(rates)} Hz; "
                              "resample them to one rate first")
        return rates.pop()

    def indices_of(self, subjects):
        """Indices of the recordings of the given subjects."""
        wanted = set(subjects)
        unknown = wanted - set(self.subjects)
        if unknown:
            raise KeyError(f"{self.name}: no recordings of subject(s) {sorted(unknown)}")
        return [i for i, r in enumerate(self.recordings) if r.subject in wanted]


def check_recording(rec, classes, where):
    """Raises FormatError (naming `where`) unless `rec` is consistent."""
    x = rec.samples
    if not isinstance(x, np.ndarray) or x.ndim != 2 or x.shape[0] < 1:
        raise FormatError(f"{where}: samples must be an (N >= 1, channels) array, "
                          f"got {getattr(x, 'shape', type(x).__name__)}")
    if not rec.sensors or x.shape[1] != 6 * len(rec.sensors):
        raise FormatError(f"{where}: {x.shape[1]} channels for sensors {rec.sensors}: "
                          "expected 6 per sensor (ax ay az gx gy gz)")
    if not np.all(np.isfinite(x)):
        row, col = np.argwhere(~np.isfinite(x))[0]
        raise FormatError(f"{where}: sample {row} channel {col} is {x[row, col]}")
    if not (np.isfinite(rec.rate_hz) and rec.rate_hz > 0):
        raise FormatError(f"{where}: rate_hz must be positive, got {rec.rate_hz}")
    y = rec.labels
    if y.shape != (x.shape[0],) or y.dtype != np.int64:
        raise FormatError(f"{where}: labels must be int64 of shape ({x.shape[0]},), "
                          f"got {y.dtype} {y.shape}")
    bad = (y < -1) | (y >= len(classes))
    if np.any(bad):
        i = int(np.argmax(bad))
        raise FormatError(f"{where}: label {y[i]} of sample {i} is not a class index "
                          f"0..{len(classes) - 1} (or -1 for none)")
    if rec.scene is not None and len(rec.scene.sensors) != len(rec.sensors):
        raise FormatError(f"{where}: scene.sensors {rec.scene.sensors} must name one scene sensor "
                          f"per recording sensor {rec.sensors}")
    if rec.scene is not None and rec.scene.bias is not None:
        b = np.asarray(rec.scene.bias)
        if b.shape != (len(rec.sensors), 6) or not np.all(np.isfinite(b)):
            raise FormatError(f"{where}: scene.bias must be {len(rec.sensors)} finite rows of 6 "
                              f"(ax ay az gx gy gz), got shape {b.shape}")


def _require(cond, msg):
    if not cond:
        raise FormatError(msg)


def _unique_keys(pairs):
    """A JSON object that gives no key twice (as every imukit JSON reader requires)."""
    out = {}
    for k, v in pairs:
        if k in out:
            raise FormatError(f"duplicate key '{k}': each key may appear once in an object")
        out[k] = v
    return out


def read_recordings(folder):
    """Reads `folder/recordings.json` and the arrays it names; FormatError on anything malformed."""
    index = os.path.join(folder, "recordings.json")
    try:
        with open(index, encoding="utf-8") as f:
            doc = json.load(f, object_pairs_hook=_unique_keys)
    except FormatError as e:
        raise FormatError(f"{index}: {e}") from None
    except FileNotFoundError:
        raise FormatError(f"{index}: no such file") from None
    except json.JSONDecodeError as e:
        raise FormatError(f"{index}:{e.lineno}:{e.colno}: {e.msg}") from None
    _require(isinstance(doc, dict), f"{index}: expected a JSON object")
    _require(doc.get("schema") == SCHEMA, f"{index}: schema: expected \"{SCHEMA}\", got {doc.get('schema')!r}")
    known = {"schema", "name", "rate_hz", "classes", "units", "recordings"}
    for k in doc:
        _require(k in known, f"{index}: unknown key '{k}' ({', '.join(sorted(known))})")
    classes = doc.get("classes")
    _require(isinstance(classes, list) and classes and all(isinstance(c, str) for c in classes),
             f"{index}: classes: expected a non-empty list of class names")
    _require(len(set(classes)) == len(classes), f"{index}: classes: a name appears twice")
    units = doc.get("units", {"accelerometer": "m/s^2", "gyroscope": "rad/s"})
    _require(units == {"accelerometer": "m/s^2", "gyroscope": "rad/s"},
             f"{index}: units: samples are stored in m/s^2 and rad/s, got {units}")
    default_rate = doc.get("rate_hz")
    entries = doc.get("recordings")
    _require(isinstance(entries, list) and entries, f"{index}: recordings: expected a non-empty list")
    out = []
    seen = set()
    rec_keys = {"id", "subject", "samples", "rate_hz", "sensors", "label", "labels", "scene"}
    for i, e in enumerate(entries):
        where = f"{index}: recordings[{i}]"
        _require(isinstance(e, dict), f"{where}: expected an object")
        for k in e:
            _require(k in rec_keys, f"{where}: unknown key '{k}' ({', '.join(sorted(rec_keys))})")
        for k in ("id", "subject", "samples", "sensors"):
            _require(k in e, f"{where}: '{k}' missing")
        # Strings, not coerced: subject 1 and "1" would be one subject of leave-one-subject-out.
        for k in ("id", "subject", "samples"):
            _require(isinstance(e[k], str) and e[k], f"{where}.{k}: expected a non-empty string, got {e[k]!r}")
        rid = e["id"]
        _require(rid not in seen, f"{where}: duplicate id '{rid}'")
        seen.add(rid)
        rate = e.get("rate_hz", default_rate)
        _require(isinstance(rate, (int, float)) and not isinstance(rate, bool),
                 f"{where}: rate_hz missing (here or at the top level)")
        sensors = e["sensors"]
        _require(isinstance(sensors, list) and sensors and all(isinstance(s, str) for s in sensors),
                 f"{where}: sensors: expected a non-empty list of names")
        path = os.path.join(folder, e["samples"])
        try:
            x = np.load(path, allow_pickle=False)
        except (OSError, ValueError) as err:
            raise FormatError(f"{where}.samples: {path}: {err}") from None
        _require(x.dtype in (np.float32, np.float64), f"{where}.samples: {path}: dtype {x.dtype}, "
                 "expected float32 or float64")
        x = np.ascontiguousarray(x, dtype=np.float64)
        n = len(x) if x.ndim >= 1 else 0
        _require(("label" in e) != ("labels" in e), f"{where}: give either 'label' (one class for the "
                 "whole recording) or 'labels' (an int64 .npy, one per sample)")
        if "label" in e:
            lab = e["label"]
            _require(isinstance(lab, int) and not isinstance(lab, bool),
                     f"{where}.label: expected a class index, got {lab!r}")
            _require(0 <= lab < len(classes), f"{where}.label: {lab} is not a class index 0..{len(classes) - 1}")
            y = np.full(n, lab, np.int64)
        else:
            lpath = os.path.join(folder, e["labels"])
            try:
                y = np.load(lpath, allow_pickle=False)
            except (OSError, ValueError) as err:
                raise FormatError(f"{where}.labels: {lpath}: {err}") from None
            _require(y.dtype == np.int64, f"{where}.labels: {lpath}: dtype {y.dtype}, expected int64")
        scene = None
        if "scene" in e:
            s = e["scene"]
            _require(isinstance(s, dict) and "file" in s and "sensors" in s,
                     f"{where}.scene: expected {{\"file\": ..., \"sensors\": [...], \"time_offset_s\": ...}}")
            _require(isinstance(s["file"], str) and s["file"], f"{where}.scene.file: expected a file name")
            _require(isinstance(s["sensors"], list) and s["sensors"] and all(isinstance(n, str) for n in s["sensors"]),
                     f"{where}.scene.sensors: expected a non-empty list of sensor names, got {s['sensors']!r}")
            for k in s:
                _require(k in ("file", "sensors", "time_offset_s", "bias"), f"{where}.scene: unknown key '{k}'")
            offset = s.get("time_offset_s", 0.0)
            _require(isinstance(offset, (int, float)) and not isinstance(offset, bool) and np.isfinite(offset),
                     f"{where}.scene.time_offset_s: expected seconds, got {offset!r}")
            bias = s.get("bias")
            try:
                bias = None if bias is None else np.asarray(bias, np.float64)
            except (TypeError, ValueError):
                raise FormatError(f"{where}.scene.bias: expected rows of 6 numbers") from None
            scene = SceneRef(path=os.path.join(folder, s["file"]), sensors=list(s["sensors"]),
                             time_offset_s=float(offset), bias=bias)
        rec = Recording(id=rid, subject=e["subject"], samples=x, labels=y, rate_hz=float(rate),
                        sensors=list(sensors), scene=scene)
        check_recording(rec, classes, f"{where} ({path})")
        out.append(rec)
    return Recordings(name=str(doc.get("name", os.path.basename(os.path.abspath(folder)))),
                      classes=list(classes), recordings=out)


def write_recordings(folder, recordings):
    """Writes `recordings` as `folder/recordings.json` plus `<id>.npy` (and `<id>.labels.npy` where
    the labels vary within a recording). Scene paths are written relative to the folder."""
    os.makedirs(folder, exist_ok=True)
    rates = {r.rate_hz for r in recordings.recordings}
    top_rate = rates.pop() if len(rates) == 1 else None
    entries = []
    for i, r in enumerate(recordings.recordings):
        check_recording(r, recordings.classes, f"recordings[{i}] ({r.id})")
        e = {"id": r.id, "subject": r.subject, "samples": f"{r.id}.npy", "sensors": list(r.sensors)}
        np.save(os.path.join(folder, e["samples"]), r.samples)
        if top_rate is None:
            e["rate_hz"] = r.rate_hz
        if len(r.labels) and np.all(r.labels == r.labels[0]) and r.labels[0] >= 0:
            e["label"] = int(r.labels[0])
        else:
            e["labels"] = f"{r.id}.labels.npy"
            np.save(os.path.join(folder, e["labels"]), r.labels)
        if r.scene is not None:
            e["scene"] = {"file": os.path.relpath(r.scene.path, folder), "sensors": list(r.scene.sensors),
                          "time_offset_s": r.scene.time_offset_s}
            if r.scene.bias is not None:
                e["scene"]["bias"] = np.asarray(r.scene.bias).tolist()
        entries.append(e)
    doc = {"schema": SCHEMA, "name": recordings.name, "classes": list(recordings.classes),
           "units": {"accelerometer": "m/s^2", "gyroscope": "rad/s"}}
    if top_rate is not None:
        doc["rate_hz"] = top_rate
    doc["recordings"] = entries
    with open(os.path.join(folder, "recordings.json"), "w", encoding="utf-8") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
