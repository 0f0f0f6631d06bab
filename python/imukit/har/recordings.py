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
import math
import numbers
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


def check_recording(rec, classes, where, what=None, labels_file=None):
    """Raises FormatError unless `rec` is consistent. Errors name `where` (the JSON path), with
    `what` (the samples file, or the recording's id) after it for the samples, and the labels
    file where the labels came from one of their own."""
    at = f"{where} ({what})" if what else where
    at_labels = f"{where}.labels ({labels_file})" if labels_file else at
    x = rec.samples
    if not isinstance(x, np.ndarray) or x.ndim != 2 or x.shape[0] < 1:
        raise FormatError(f"{at}: samples must be an (N >= 1, channels) array, "
                          f"got {getattr(x, 'shape', type(x).__name__)}")
    if not (isinstance(rec.sensors, list) and rec.sensors and all(isinstance(s, str) for s in rec.sensors)):
        raise FormatError(f"{at}: sensors must be a non-empty list of names, got {rec.sensors!r}")
    if x.shape[1] != 6 * len(rec.sensors):
        raise FormatError(f"{at}: {x.shape[1]} channels for sensors {rec.sensors}: "
                          "expected 6 per sensor (ax ay az gx gy gz)")
    if not np.all(np.isfinite(x)):
        row, col = np.argwhere(~np.isfinite(x))[0]
        raise FormatError(f"{at}: sample {row} channel {col} is {x[row, col]}")
    if not (_is_number(rec.rate_hz) and rec.rate_hz > 0):
        raise FormatError(f"{at}: rate_hz: expected a positive number of Hz, got {rec.rate_hz!r}")
    y = rec.labels
    if not isinstance(y, np.ndarray) or y.shape != (x.shape[0],) or y.dtype != np.int64:
        raise FormatError(f"{at_labels}: labels must be int64 of shape ({x.shape[0]},), "
                          f"got {getattr(y, 'dtype', type(y).__name__)} {getattr(y, 'shape', '')}")
    bad = (y < -1) | (y >= len(classes))
    if np.any(bad):
        i = int(np.argmax(bad))
        raise FormatError(f"{at_labels}: label {y[i]} of sample {i} is not a class index "
                          f"0..{len(classes) - 1} (or -1 for none)")
    if rec.scene is None:
        return
    # Found in review: a scene that is not there failed only when PPDA first used it, hours
    # into an experiment.
    if not os.path.isfile(rec.scene.path):
        raise FormatError(f"{where}.scene.file: {rec.scene.path}: no such file")
    if not (isinstance(rec.scene.sensors, list) and all(isinstance(s, str) and s for s in rec.scene.sensors)
            and len(rec.scene.sensors) == len(rec.sensors)):
        raise FormatError(f"{where}.scene.sensors: {rec.scene.sensors!r} must name one scene sensor "
                          f"per recording sensor {rec.sensors}")
    if not _is_number(rec.scene.time_offset_s):
        raise FormatError(f"{where}.scene.time_offset_s: expected seconds, got {rec.scene.time_offset_s!r}")
    if rec.scene.bias is not None:
        b = np.asarray(rec.scene.bias)
        # Numbers only: NumPy would take strings and booleans (found in review, 2026-11-27).
        if b.shape != (len(rec.sensors), 6) or b.dtype.kind not in "fiu":
            raise FormatError(f"{where}.scene.bias: expected {len(rec.sensors)} rows of 6 numbers "
                              f"(ax ay az gx gy gz), got {b.dtype} of shape {b.shape}")
        if not np.all(np.isfinite(b)):
            row, col = np.argwhere(~np.isfinite(b))[0]
            raise FormatError(f"{where}.scene.bias[{row}][{col}]: {b[row, col]} is not finite")


def check_same_channels(rec, first, where):
    """Windows of all recordings go into one array, so every recording has the channel count
    of the first."""
    if rec.samples.shape[1] != first.samples.shape[1]:
        raise FormatError(f"{where}: {rec.samples.shape[1]} channels where recordings[0] ({first.id}) has "
                          f"{first.samples.shape[1]}: every recording needs the same channel count")


def check_sensor_order(rec, i, where, seen):
    """Channels are stacked by position, so a sensor named by two recordings is the same channel
    block of both (found in review, 2026-11-27: ["wrist", "ankle"] and ["ankle", "wrist"] were
    trained on wrist over ankle). Different names are allowed (UTD-MHAD: wrist or thigh).
    `seen` maps each name to (block, index, recording) of the first recording naming it."""
    for block, name in enumerate(rec.sensors):
        first_block, j, other = seen.setdefault(name, (block, i, rec))
        if first_block != block:
            raise FormatError(f"{where}: sensors {rec.sensors} where recordings[{j}] ({other.id}) has "
                              f"{other.sensors}: sensor '{name}' is channel block {block} here and "
                              f"{first_block} there: list the sensors in one order")


def check_sensor_orders(recordings):
    """check_sensor_order over a whole Recordings (made in memory, not read)."""
    seen = {}
    for i, r in enumerate(recordings.recordings):
        check_sensor_order(r, i, f"{recordings.name}: recordings[{i}] ({r.id})", seen)


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


def _is_number(value):
    """A finite real number, not a bool (NumPy scalars included). A JSON integer too large for
    a float is not one (found in review, 2026-11-27: np.isfinite raised a TypeError on it)."""
    if not isinstance(value, numbers.Real) or isinstance(value, (bool, np.bool_)):
        return False
    try:
        return math.isfinite(float(value))
    except OverflowError:
        return False


def _rate(value, where):
    """A sample rate from the JSON: a positive finite number of Hz."""
    _require(_is_number(value) and value > 0, f"{where}: expected a positive number of Hz, got {value!r}")
    return float(value)


def _bias(bias, where):
    """scene.bias from the JSON: rows of 6 JSON numbers (not strings or booleans, which NumPy
    would convert: found in review, 2026-11-27); the row count is check_recording's."""
    _require(isinstance(bias, list) and bias, f"{where}: expected a list of rows of 6 numbers, got {bias!r}")
    for r, row in enumerate(bias):
        _require(isinstance(row, list) and len(row) == 6,
                 f"{where}[{r}]: expected 6 numbers (ax ay az gx gy gz), got {row!r}")
        for c, v in enumerate(row):
            _require(isinstance(v, (int, float)) and not isinstance(v, bool),
                     f"{where}[{r}][{c}]: expected a number, got {v!r}")
            _require(_is_number(v), f"{where}[{r}][{c}]: {v!r} is not finite")
    return np.array(bias, np.float64)


def _load_array(path, where, kind, sizes, expected):
    """The array of a .npy file, in native byte order, whose dtype is of `kind` ('f', 'i') and
    one of the item `sizes`; FormatError naming `where` and the file otherwise."""
    # The magic first: np.load blamed any other file (a CSV, an empty file) on "pickled data"
    # (found in review, 2026-11-27), and it opens an .npz archive as well.
    try:
        with open(path, "rb") as f:
            head = f.read(6)
    except OSError as err:
        raise FormatError(f"{where}: {path}: {err}") from None
    _require(not head.startswith(b"PK"), f"{where}: {path}: an .npz archive, expected a .npy file")
    _require(head == b"\x93NUMPY", f"{where}: {path}: not a .npy file "
             + ("(empty)" if not head else f"(starts with {head!r})"))
    try:
        a = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as err:
        raise FormatError(f"{where}: {path}: {err}") from None
    # Either byte order, as the C++ reader takes (a big-endian file is as good a file).
    _require(a.dtype.kind == kind and a.dtype.itemsize in sizes,
             f"{where}: {path}: dtype {a.dtype}, expected {expected}")
    return a.astype(a.dtype.newbyteorder("="), copy=False)


def read_json_file(path, object_pairs_hook=None):
    """A JSON file's document; FormatError naming the file (and line:column, or the byte of
    text that is not UTF-8) when it cannot be read or parsed."""
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f, object_pairs_hook=object_pairs_hook)
    except FormatError as e:
        raise FormatError(f"{path}: {e}") from None
    except FileNotFoundError:
        raise FormatError(f"{path}: no such file") from None
    except OSError as e:
        raise FormatError(f"{path}: {e.strerror}") from None
    except json.JSONDecodeError as e:
        raise FormatError(f"{path}:{e.lineno}:{e.colno}: {e.msg}") from None
    except UnicodeDecodeError as e:
        raise FormatError(f"{path}: not UTF-8 text ({e.reason} at byte {e.start})") from None


def read_json_object(path, object_pairs_hook=None):
    """read_json_file's document when it is a JSON object; FormatError naming the file otherwise."""
    doc = read_json_file(path, object_pairs_hook)
    _require(isinstance(doc, dict), f"{path}: expected a JSON object")
    return doc


def read_recordings(folder):
    """Reads `folder/recordings.json` and the arrays it names; FormatError on anything malformed."""
    index = os.path.join(folder, "recordings.json")
    doc = read_json_object(index, object_pairs_hook=_unique_keys)
    _require(doc.get("schema") == SCHEMA, f"{index}: schema: expected \"{SCHEMA}\", got {doc.get('schema')!r}")
    known = {"schema", "name", "rate_hz", "classes", "units", "recordings"}
    for k in doc:
        _require(k in known, f"{index}: unknown key '{k}' ({', '.join(sorted(known))})")
    name = doc.get("name", os.path.basename(os.path.abspath(folder)))
    _require(isinstance(name, str) and name, f"{index}: name: expected a non-empty string, got {name!r}")
    classes = doc.get("classes")
    _require(isinstance(classes, list) and classes and all(isinstance(c, str) for c in classes),
             f"{index}: classes: expected a non-empty list of class names")
    _require(len(set(classes)) == len(classes), f"{index}: classes: a name appears twice")
    units = doc.get("units", {"accelerometer": "m/s^2", "gyroscope": "rad/s"})
    _require(units == {"accelerometer": "m/s^2", "gyroscope": "rad/s"},
             f"{index}: units: samples are stored in m/s^2 and rad/s, got {units}")
    # Checked even where every recording gives its own: a value no recording reads is still wrong.
    default_rate = _rate(doc["rate_hz"], f"{index}: rate_hz") if "rate_hz" in doc else None
    entries = doc.get("recordings")
    _require(isinstance(entries, list) and entries, f"{index}: recordings: expected a non-empty list")
    out = []
    seen = set()
    sensor_blocks = {}
    # Found in review, 2026-11-27: two entries could read one file (a.npy, ./a.npy) under two
    # subjects, so a test subject's windows were training windows too.
    file_owner = {}

    def own_file(file, at):
        other = file_owner.setdefault(os.path.realpath(file), at)
        _require(other == at, f"{index}: {at}: {file} is the file of {other} too: each recording needs its own files")
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
        if "rate_hz" in e:
            rate = _rate(e["rate_hz"], f"{where}.rate_hz")
        else:
            _require(default_rate is not None, f"{where}: rate_hz missing (here or at the top level)")
            rate = default_rate
        sensors = e["sensors"]
        _require(isinstance(sensors, list) and sensors and all(isinstance(s, str) for s in sensors),
                 f"{where}: sensors: expected a non-empty list of names")
        path = os.path.join(folder, e["samples"])
        x = _load_array(path, f"{where}.samples", "f", (4, 8), "float32 or float64")
        own_file(path, f"recordings[{i}].samples")
        x = np.ascontiguousarray(x, dtype=np.float64)
        n = len(x) if x.ndim >= 1 else 0
        _require(("label" in e) != ("labels" in e), f"{where}: give either 'label' (one class for the "
                 "whole recording) or 'labels' (an int64 .npy, one per sample)")
        lpath = None
        if "label" in e:
            lab = e["label"]
            _require(isinstance(lab, int) and not isinstance(lab, bool),
                     f"{where}.label: expected a class index, got {lab!r}")
            _require(0 <= lab < len(classes), f"{where}.label: {lab} is not a class index 0..{len(classes) - 1}")
            y = np.full(n, lab, np.int64)
        else:
            _require(isinstance(e["labels"], str) and e["labels"],
                     f"{where}.labels: expected a file name, got {e['labels']!r}")
            lpath = os.path.join(folder, e["labels"])
            y = _load_array(lpath, f"{where}.labels", "i", (8,), "int64")
            own_file(lpath, f"recordings[{i}].labels")
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
            _require(isinstance(offset, (int, float)) and _is_number(offset),
                     f"{where}.scene.time_offset_s: expected seconds, got {offset!r}")
            bias = None if s.get("bias") is None else _bias(s["bias"], f"{where}.scene.bias")
            scene = SceneRef(path=os.path.join(folder, s["file"]), sensors=list(s["sensors"]),
                             time_offset_s=float(offset), bias=bias)
        rec = Recording(id=rid, subject=e["subject"], samples=x, labels=y, rate_hz=rate,
                        sensors=list(sensors), scene=scene)
        check_recording(rec, classes, where, path, lpath)
        if out:
            check_same_channels(rec, out[0], f"{where} ({path})")
        check_sensor_order(rec, i, f"{where} ({path})", sensor_blocks)
        out.append(rec)
    return Recordings(name=name, classes=list(classes), recordings=out)


def _file_stem(rid, where):
    """A recording id as the stem of the files it is written to: one name inside the folder."""
    seps = {"/", "\0", os.sep, os.altsep} - {None}
    _require(isinstance(rid, str) and rid not in ("", ".", "..") and not any(c in rid for c in seps),
             f"{where}: id {rid!r} cannot name a file in the folder (no '/', not empty, '.' or '..')")
    return rid


def write_recordings(folder, recordings):
    """Writes `recordings` as `folder/recordings.json` plus `<id>.npy` (and `<id>.labels.npy` where
    the labels vary within a recording). Scene paths are written relative to the folder.
    Everything is checked, and the index made as text, before the first file is written (found
    in review: an error in a later recording left the earlier ones' files and no index); the
    index is written last, under a temporary name moved into place (found in review,
    2026-11-27: a NumPy rate failed json.dump halfway and left half an index). So the folder
    reads as before or as written, never half written, and what is written reads back."""
    classes = recordings.classes
    _require(isinstance(recordings.name, str) and recordings.name,
             f"name: expected a non-empty string, got {recordings.name!r}")
    _require(isinstance(classes, list) and classes and all(isinstance(c, str) for c in classes)
             and len(set(classes)) == len(classes), f"classes: expected distinct class names, got {classes!r}")
    _require(len(recordings.recordings) > 0, "recordings: expected at least one")
    entries, arrays, index_of_id, owner, sensor_blocks = [], [], {}, {}, {}
    for i, r in enumerate(recordings.recordings):
        where = f"recordings[{i}]"
        stem = _file_stem(r.id, where)
        _require(r.id not in index_of_id, f"{where}: duplicate id '{r.id}' (recordings[{index_of_id.get(r.id)}])")
        index_of_id[r.id] = i
        _require(isinstance(r.subject, str) and r.subject,
                 f"{where}.subject: expected a non-empty string, got {r.subject!r}")
        check_recording(r, classes, where, r.id)
        if i:
            check_same_channels(r, recordings.recordings[0], f"{where} ({r.id})")
        check_sensor_order(r, i, f"{where} ({r.id})", sensor_blocks)
        # Plain str, float and int: json cannot write NumPy scalars (np.float32 after resampling).
        e = {"id": str(r.id), "subject": str(r.subject), "samples": f"{stem}.npy",
             "sensors": [str(s) for s in r.sensors], "rate_hz": float(r.rate_hz)}
        files = [(e["samples"], r.samples)]
        if np.all(r.labels == r.labels[0]) and r.labels[0] >= 0:
            e["label"] = int(r.labels[0])
        else:
            e["labels"] = f"{stem}.labels.npy"
            files.append((e["labels"], r.labels))
        # Ids are unique as the reader requires, and so are the files they name (id "a.labels"
        # would take the labels file of id "a").
        for name, _ in files:
            _require(name not in owner, f"{where} ({r.id}): its file {name} is recordings[{owner.get(name)}]'s too")
            owner[name] = i
        if r.scene is not None:
            e["scene"] = {"file": os.path.relpath(r.scene.path, folder), "sensors": [str(s) for s in r.scene.sensors],
                          "time_offset_s": float(r.scene.time_offset_s)}
            if r.scene.bias is not None:
                e["scene"]["bias"] = np.asarray(r.scene.bias, np.float64).tolist()
        entries.append(e)
        arrays += files
    doc = {"schema": SCHEMA, "name": str(recordings.name), "classes": [str(c) for c in classes],
           "units": {"accelerometer": "m/s^2", "gyroscope": "rad/s"}}
    rates = {e["rate_hz"] for e in entries}
    if len(rates) == 1:
        doc["rate_hz"] = rates.pop()
        for e in entries:
            del e["rate_hz"]
    doc["recordings"] = entries
    text = json.dumps(doc, indent=1) + "\n"
    os.makedirs(folder, exist_ok=True)
    for name, a in arrays:
        np.save(os.path.join(folder, name), a)
    index = os.path.join(folder, "recordings.json")
    tmp = os.path.join(folder, f".recordings.json.{os.getpid()}.tmp")
    try:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, index)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
